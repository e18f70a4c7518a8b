//! Scene files: `--scene-file FILE.toml` holds any of the flags as `key = value` (the long flag's
//! name, `grid = 64`, `pin-box = [-1, 0.9, -1, 1, 1, 1]`, `no-timestamps = true`, a list of
//! strings for a flag given once per item, `cloth-mesh = ["a.obj", "b.obj"]`,
//! `piece-stiffness = ["2=160,0,8"]`), and flags typed
//! on the command line override it. The file's values go through the flags' own parsers and
//! checks, so a bad value gets the flag's message, prefixed with the file, line and key. An
//! unknown key or a value of the wrong kind is a usage error naming the key and its line.
//! `--print-scene` writes the effective scene (file, flags and defaults) in the same form.
//!
//! Beyond the flags, a scene file adds colliders as `[[collider]]` tables (see
//! `super::colliders::ColliderTable`): a mesh, its placement and its motion, as many as wanted.

use super::args::{Args, unused};
use super::colliders::{BUILT_IN_MESHES, ColliderTable};
use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// Flags a scene file cannot hold (they are about reading or printing scene files).
const NOT_IN_FILES: [&str; 4] = ["help", "version", "scene_file", "print_scene"];

/// Keys naming files the run reads (meshes): a relative path is found beside the scene file,
/// as a scene and its models travel together. Outputs (`json`, `obj-dir`, ...) stay relative to
/// the working directory, where the run writes.
const READ_FROM_FILES: [&str; 2] = ["mesh", "cloth_mesh"];

/// Keys whose value is a path (read or written): a string, never a number taken for a name.
const PATHS: [&str; 6] = ["mesh", "cloth_mesh", "usd", "json", "obj_dir", "png_dir"];

/// Mesh `value` (key `id`) read relative to directory `dir`: a relative path made absolute
/// from it (so `--print-scene` writes a path that reads back from anywhere); absolute paths,
/// and built-in mesh names where a collider is meant (`mesh`), as they are.
fn beside(dir: &Path, id: &str, value: &str) -> String {
    let path = Path::new(value);
    let built_in = id == "mesh" && BUILT_IN_MESHES.contains(&value);
    if built_in || path.is_absolute() || value.is_empty() {
        return value.to_string();
    }
    let joined = dir.join(path);
    std::path::absolute(&joined).unwrap_or(joined).display().to_string()
}

/// The directory scene file `path` is in (its meshes' base).
fn scene_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// The `[[collider]]` tables of a scene file, each with where it is in the file.
#[derive(Debug, Default, serde::Deserialize)]
struct ColliderTables {
    #[serde(default)]
    collider: Vec<toml::Spanned<ColliderTable>>,
}

/// The `[[collider]]` tables as `--print-scene` writes them.
#[derive(serde::Serialize)]
struct PrintedColliders<'a> {
    collider: &'a [ColliderTable],
}

/// Which flags the scene file set (those the command line did not override), so an error about
/// one names the file's line rather than a flag the user never typed.
#[derive(Default)]
pub(crate) struct FileFlags {
    path: PathBuf,
    /// Each flag's id, the file's key for it and its line.
    keys: Vec<(String, String, usize)>,
}

impl FileFlags {
    /// Where flag `id` was set, when the scene file set it: " (`key` on line N of scene file
    /// F)"; else nothing.
    pub(crate) fn origin(&self, id: &str) -> String {
        match self.keys.iter().find(|(flag, _, _)| flag == id) {
            Some((_, key, line)) => format!(" (`{key}` on line {line} of scene file {})", self.path.display()),
            None => String::new(),
        }
    }
}

/// The command line's matches with the scene file's flags (if any) underneath, the file's
/// `[[collider]]` tables, and which flags the file set.
pub(crate) fn matches(cli: Vec<OsString>) -> Result<(ArgMatches, Vec<ColliderTable>, FileFlags), clap::Error> {
    let first = Args::command().try_get_matches_from(&cli)?;
    let Some(path) = first.get_one::<std::path::PathBuf>("scene_file").cloned() else {
        return Ok((first, Vec::new(), FileFlags::default()));
    };
    let text = std::fs::read_to_string(&path)
        .map_err(|e| Args::command().error(ErrorKind::Io, format!("--scene-file {}: {e}", path.display())))?;
    let entries = file_flags(&path, &text)?;
    let mut colliders = collider_tables(&path, &text)?;
    for table in &mut colliders {
        table.mesh = beside(scene_dir(&path), "mesh", &table.mesh);
        table.mesh_sequence = table.mesh_sequence.as_ref().map(|m| beside(scene_dir(&path), "mesh_sequence", m));
    }
    let mut merged = vec![cli[0].clone()];
    let mut file_flags = FileFlags { path: path.clone(), keys: Vec::new() };
    for entry in &entries {
        // A flag typed on the command line overrides the file.
        if first.value_source(&entry.id) != Some(ValueSource::CommandLine) {
            merged.extend(entry.args.iter().map(OsString::from));
            file_flags.keys.push((entry.id.clone(), entry.key.clone(), entry.line));
        }
    }
    merged.extend(cli.into_iter().skip(1));
    let matches = Args::command().try_get_matches_from(merged).map_err(|e| locate(e, &path, &entries))?;
    Ok((matches, colliders, file_flags))
}

/// A usage error said of the scene file's line.
fn file_error(path: &Path, line: usize, problem: String) -> clap::Error {
    Args::command().error(ErrorKind::ValueValidation, format!("scene file {}, line {line}: {problem}", path.display()))
}

/// The file's `[[collider]]` tables, each checked; errors name the table's line and key.
fn collider_tables(path: &Path, text: &str) -> Result<Vec<ColliderTable>, clap::Error> {
    let tables: ColliderTables = toml::from_str(text).map_err(|e| {
        let line = e.span().map_or(0, |s| line_at(text, s.start));
        // The key set on that line, when the error is about a value (line 0: unknown).
        let key = (line > 0)
            .then(|| text.lines().nth(line - 1))
            .flatten()
            .and_then(|l| l.split_once('='))
            .map(|(k, _)| format!(", key `{}`", k.trim()))
            .unwrap_or_default();
        file_error(path, line, format!("in a [[collider]] table{key}: {}", e.message()))
    })?;
    for (i, table) in tables.collider.iter().enumerate() {
        table.get_ref().check().map_err(|problem| {
            file_error(path, line_at(text, table.span().start), format!("[[collider]] number {}: {problem}", i + 1))
        })?;
    }
    Ok(tables.collider.into_iter().map(toml::Spanned::into_inner).collect())
}

/// One key of a scene file as command-line arguments.
struct Entry {
    id: String,
    key: String,
    line: usize,
    args: Vec<String>,
}

/// The scene file's keys as flags, in file order.
fn file_flags(path: &Path, text: &str) -> Result<Vec<Entry>, clap::Error> {
    let usage = |line: usize, problem: String| file_error(path, line, problem);
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let line = e.span().map_or(0, |s| line_at(text, s.start));
        usage(line, e.message().to_string())
    })?;
    let command = Args::command();
    let mut entries = Vec::new();
    for (key, value) in &table {
        let id = key.replace('-', "_");
        let line = line_of(text, key);
        if key == "collider" {
            if value.as_array().is_some_and(|tables| tables.iter().all(toml::Value::is_table)) {
                continue; // `[[collider]]` tables: read by `collider_tables`
            }
            return Err(usage(
                line,
                "a collider is a `[[collider]]` table, in double brackets (one per collider), not `[collider]` or \
                 `collider = ...`"
                    .into(),
            ));
        }
        let arg = command
            .get_arguments()
            .find(|a| a.get_id().as_str() == id && !NOT_IN_FILES.contains(&a.get_id().as_str()))
            .ok_or_else(|| {
                usage(line, format!("unknown key `{key}`: the keys are the long flags (`drape --help` lists them)"))
            })?;
        let flag = format!("--{}", arg.get_long().unwrap_or(&id));
        let args = if given_per_item(arg, &id) && value.is_array() {
            // A flag given again per item (`cloth-mesh = ["a.obj", "b.obj"]`): once per item.
            let what = if READ_FROM_FILES.contains(&id.as_str()) {
                "a path or a list of paths"
            } else {
                "a string or a list of strings"
            };
            let items =
                string_list(value).ok_or_else(|| usage(line, format!("`{key}` takes {what} (strings), not empty")))?;
            let read = |f: &String| {
                if READ_FROM_FILES.contains(&id.as_str()) { beside(scene_dir(path), &id, f) } else { f.clone() }
            };
            items.iter().map(|f| format!("{flag}={}", read(f))).collect()
        } else if arg.get_action().takes_values() {
            if PATHS.contains(&id.as_str()) && !value.is_str() {
                return Err(usage(line, format!("`{key}` takes a path: a string, in quotes")));
            }
            let mut value = flag_value(value).ok_or_else(|| usage(line, format!("`{key}` takes {}", kind_of(arg))))?;
            if READ_FROM_FILES.contains(&id.as_str()) {
                value = beside(scene_dir(path), &id, &value);
            }
            // One token: a value that starts with `-` (a negative number) is not taken for a flag.
            vec![format!("{flag}={value}")]
        } else {
            match value {
                toml::Value::Boolean(true) => vec![flag.clone()],
                toml::Value::Boolean(false) => Vec::new(),
                _ => return Err(usage(line, format!("`{key}` is a switch: true or false"))),
            }
        };
        if let Some(earlier) = entries.iter().find(|e: &&Entry| e.id == id) {
            return Err(usage(line, format!("`{}` and `{key}` both set {flag}: keep one", earlier.key)));
        }
        entries.push(Entry { id, key: key.clone(), line, args });
    }
    entries.sort_by_key(|e| e.line);
    Ok(entries)
}

/// Flags given again per item whose scene-file value may be a list of strings, one item each:
/// the cloth's pieces (`cloth-mesh`) and their own materials (`piece-stiffness`, ...).
const GIVEN_PER_ITEM: [&str; 3] = ["cloth_mesh", "piece_stiffness", "piece_density"];

/// Whether key `id` is a flag given again per item (`GIVEN_PER_ITEM`).
fn given_per_item(arg: &clap::Arg, id: &str) -> bool {
    GIVEN_PER_ITEM.contains(&id) && matches!(arg.get_action(), clap::ArgAction::Append)
}

/// A list of strings (`given_per_item`); None when it is empty or holds anything but strings.
fn string_list(value: &toml::Value) -> Option<Vec<String>> {
    let items = value.as_array().filter(|items| !items.is_empty())?;
    items.iter().map(|v| v.as_str().map(str::to_string)).collect()
}

/// What a flag's value looks like, for the wrong-kind message.
fn kind_of(arg: &clap::Arg) -> String {
    let values: Vec<String> = arg.get_possible_values().iter().map(|v| format!("\"{}\"", v.get_name())).collect();
    if values.is_empty() {
        "a number, a string or a list of numbers".into()
    } else {
        format!("one of {}", values.join(", "))
    }
}

/// A TOML value as one flag value: strings as they are, numbers in full, lists of numbers comma
/// separated (the vector flags' form); None for tables, dates and other lists.
fn flag_value(value: &toml::Value) -> Option<String> {
    match value {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(f.to_string()),
        toml::Value::Array(items) => {
            let parts: Option<Vec<String>> = items
                .iter()
                .map(|v| match v {
                    toml::Value::Integer(i) => Some(i.to_string()),
                    toml::Value::Float(f) => Some(f.to_string()),
                    _ => None,
                })
                .collect();
            parts.map(|p| p.join(","))
        }
        _ => None,
    }
}

/// The 1-based line of byte `offset` (an error at the very end is said of the last line).
fn line_at(text: &str, offset: usize) -> usize {
    let line = text.get(..offset).unwrap_or(text).matches('\n').count() + 1;
    line.min(text.lines().count().max(1))
}

/// The 1-based line where `key` is set, or opens a table (`[key]`), (0 if not found).
fn line_of(text: &str, key: &str) -> usize {
    let names = [key.to_string(), key.replace('_', "-"), key.replace('-', "_")];
    // Bare, or quoted (`"frames" = 0`, `'frames' = 0`).
    let spellings: Vec<String> = names.iter().flat_map(|k| [k.clone(), format!("\"{k}\""), format!("'{k}'")]).collect();
    text.lines()
        .position(|l| {
            let l = l.trim_start();
            let header = l.starts_with('[') && spellings.iter().any(|k| l.trim_matches(['[', ']', ' ']) == k);
            // `key = ...`, or a dotted key under it (`grid.x = 8`).
            header
                || spellings.iter().any(|k| {
                    l.strip_prefix(k.as_str()).is_some_and(|rest| {
                        let rest = rest.trim_start();
                        rest.starts_with('=') || rest.starts_with('.')
                    })
                })
        })
        .map_or(0, |i| i + 1)
}

/// A parse error of the merged arguments, said of the scene file when the flag came from it.
fn locate(error: clap::Error, path: &Path, entries: &[Entry]) -> clap::Error {
    let Some(ContextValue::String(arg)) = error.get(ContextKind::InvalidArg) else {
        return error;
    };
    let long = arg.split_whitespace().next().unwrap_or("").trim_start_matches('-').replace('-', "_");
    match entries.iter().find(|e| e.id == long) {
        Some(entry) => {
            let message = error.to_string();
            let message = message.trim_start_matches("error: ").lines().next().unwrap_or("").to_string();
            Args::command().error(
                error.kind(),
                format!("scene file {}, line {}, key `{}`: {message}", path.display(), entry.line, entry.key),
            )
        }
        None => error,
    }
}

/// The effective scene (the file's values, the flags over them, the defaults) as a scene file.
/// A flag the scene does not use is written commented out, with the reason; the file's
/// colliders follow as `[[collider]]` tables. A value that is not UTF-8 (a path's bytes) is
/// refused: a TOML file holds only UTF-8, and a lossy copy would name another file.
pub(crate) fn print(args: &Args, matches: &ArgMatches) -> Result<String, String> {
    let mut out = String::from("# drape scene: `drape --scene-file THIS.toml` runs it; flags override it.\n");
    for arg in Args::command().get_arguments() {
        let id = arg.get_id().as_str();
        if NOT_IN_FILES.contains(&id) {
            continue;
        }
        let key = arg.get_long().unwrap_or(id);
        let value = if !arg.get_action().takes_values() {
            matches.get_flag(id).to_string()
        } else {
            let Some(raw) = matches.get_raw(id) else {
                continue; // an optional flag not given: its absence is the default
            };
            let mut values = Vec::new();
            for v in raw {
                let Some(text) = v.to_str() else {
                    return Err(format!(
                        "--print-scene: the value {} of --{key} is not UTF-8, which a scene file (TOML) cannot \
                         hold; rename the file, or give a link to it whose name is UTF-8",
                        v.to_string_lossy()
                    ));
                };
                values.push(text.to_string());
            }
            if READ_FROM_FILES.contains(&id) {
                // Absolute, so the printed file reads the same mesh wherever it is saved.
                values = values.iter().map(|v| beside(Path::new("."), id, v)).collect();
            }
            if given_per_item(arg, id) && values.len() > 1 {
                // Items, each its own string (a path or a stiffness may hold a comma).
                let items = values.iter().map(|v| toml::Value::String(v.clone()).to_string());
                format!("[{}]", items.collect::<Vec<_>>().join(", "))
            } else if given_per_item(arg, id) {
                toml::Value::String(values.join(",")).to_string()
            } else {
                toml_value(&values.join(","))
            }
        };
        match unused(args, id) {
            Some(reason) => out += &format!("# {key} = {value}    # unused: {reason}\n"),
            None => out += &format!("{key} = {value}\n"),
        }
    }
    if !args.colliders.is_empty() {
        match toml::to_string(&PrintedColliders { collider: &args.colliders }) {
            Ok(text) => out += &format!("\n{text}"),
            Err(e) => out += &format!("# the [[collider]] tables could not be written: {e}\n"),
        }
    }
    Ok(out)
}

/// A flag's value as TOML: a number, a list of numbers, or a string.
fn toml_value(text: &str) -> String {
    let number = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite()).map(|_| s.trim().to_string());
    if let Some(n) = number(text) {
        return n;
    }
    let parts: Option<Vec<String>> = text.split(',').map(number).collect();
    match parts {
        Some(p) if p.len() > 1 => format!("[{}]", p.join(", ")),
        _ => toml::Value::String(text.to_string()).to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scene files mutated at random (bytes flipped, dropped, duplicated, cut short) never
    /// panic the reader: each is flags and collider tables, or an error.
    #[test]
    fn mangled_scene_files_are_errors_not_panics() {
        let valid = "scene = \"pile\"\ngrid = 32\nwind = [-1, 0, 0.5]\nno-timestamps = true\npin-box = [0, 0, 0, 1, 1, 1]\n\
                     [[collider]]\nmesh = \"torus\"\nscale = [1, 2, 1]\nspin-rate = 1.5\nvelocity = [0, -1e3, 0]\n";
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let (mut parsed, mut rejected) = (0, 0);
        for _ in 0..3000 {
            let mut bytes = valid.as_bytes().to_vec();
            for _ in 0..1 + next() % 4 {
                let at = (next() % bytes.len().max(1) as u64) as usize;
                match next() % 4 {
                    0 => bytes[at] = (next() % 128) as u8,
                    1 => {
                        bytes.remove(at);
                    }
                    2 => bytes.insert(at, b"=[]\"{},.-#\n0x"[(next() % 13) as usize]),
                    _ => bytes.truncate(at),
                }
                if bytes.is_empty() {
                    break;
                }
            }
            let text = String::from_utf8_lossy(&bytes);
            let path = Path::new("fuzz.toml");
            match file_flags(path, &text).and_then(|_| collider_tables(path, &text)) {
                Ok(_) => parsed += 1,
                Err(_) => rejected += 1,
            }
        }
        assert!(
            parsed > 0 && rejected > 0,
            "the mutations must reach both outcomes ({parsed} parsed, {rejected} rejected)"
        );
    }
}
