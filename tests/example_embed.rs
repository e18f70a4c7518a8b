//! `examples/embed` (the integrator's view) on a small scene: the picture it renders from
//! drape's vertex buffers shows the cloth exactly where `positions()` says it is.

#[path = "../examples/embed/app.rs"]
mod app;

use glam::{Mat4, Vec3, Vec4};

/// Which surface is nearest at each pixel centre: 0 = background, 1 = cloth, 2 = collider.
/// An independent CPU rasteriser (f64, z-buffer) over the simulated positions and the
/// collider's posed triangles.
fn visible_surfaces(
    view_projection: Mat4,
    width: u32,
    height: u32,
    triangles: impl Iterator<Item = ([Vec3; 3], u8)>,
) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let mut depth = vec![f64::INFINITY; w * h];
    let mut surface = vec![0u8; w * h];
    let m = view_projection.as_dmat4();
    for (corners, id) in triangles {
        let clip = corners.map(|p| m * p.as_dvec3().extend(1.0));
        if clip.iter().any(|c| c.w <= 1e-6) {
            continue; // behind the camera: never in this scene
        }
        // Screen coordinates in pixels (Vulkan: clip y already points down) and depth.
        let s = clip.map(|c| {
            let ndc = c.truncate() / c.w;
            glam::DVec3::new((ndc.x * 0.5 + 0.5) * w as f64, (ndc.y * 0.5 + 0.5) * h as f64, ndc.z)
        });
        let area = (s[1].x - s[0].x) * (s[2].y - s[0].y) - (s[1].y - s[0].y) * (s[2].x - s[0].x);
        if area.abs() < 1e-12 {
            continue;
        }
        let lo = s.iter().fold(glam::DVec2::splat(f64::INFINITY), |a, p| a.min(p.truncate()));
        let hi = s.iter().fold(glam::DVec2::splat(f64::NEG_INFINITY), |a, p| a.max(p.truncate()));
        let (x0, x1) = ((lo.x.floor().max(0.0)) as usize, (hi.x.ceil().min(w as f64)) as usize);
        let (y0, y1) = ((lo.y.floor().max(0.0)) as usize, (hi.y.ceil().min(h as f64)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let edge = |a: glam::DVec3, b: glam::DVec3| (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
                let b0 = edge(s[1], s[2]) / area;
                let b1 = edge(s[2], s[0]) / area;
                let b2 = edge(s[0], s[1]) / area;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let z = b0 * s[0].z + b1 * s[1].z + b2 * s[2].z;
                let i = y * w + x;
                if (0.0..depth[i]).contains(&z) {
                    depth[i] = z;
                    surface[i] = id;
                }
            }
        }
    }
    surface
}

#[test]
fn the_rendered_cloth_covers_the_pixels_of_its_simulated_triangles() {
    let out = std::env::temp_dir().join(format!("drape-embed-{}", std::process::id()));
    let options =
        app::Options { frames: 20, out: Some(out.clone()), every: 10, width: 200, height: 150, grid: 24, voxels: 8 };
    let outcome = app::run(&options).expect("the example runs");
    assert!(outcome.validated, "the validation layer must watch the example (install vulkan-validationlayers)");

    // Every 10th frame is written, and the file holds the rendered picture.
    let expected: Vec<_> = [10, 20].iter().map(|f| out.join(format!("frame_{f:04}.png"))).collect();
    assert_eq!(outcome.written, expected);
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&expected[1]).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut file_pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut file_pixels).unwrap();
    assert_eq!((info.width, info.height), (200, 150));
    assert_eq!(&file_pixels[..info.buffer_size()], &outcome.pixels[..]);
    std::fs::remove_dir_all(&out).ok();

    // Rendered cloth pixels: the cloth is shaded red-dominant, the collider blue-dominant.
    let rendered: Vec<bool> = outcome.pixels.as_chunks::<4>().0.iter().map(|p| p[0] > p[2]).collect();
    let cloth =
        outcome.cloth_triangles.iter().map(|t| (t.map(|i| Vec4::truncate(outcome.cloth_positions[i as usize])), 1u8));
    let collider = outcome.collider_triangles.iter().map(|t| (*t, 2u8));
    let surfaces = visible_surfaces(outcome.view_projection, outcome.width, outcome.height, cloth.chain(collider));
    let expected_cloth: Vec<bool> = surfaces.iter().map(|&s| s == 1).collect();

    let count = |v: &[bool]| v.iter().filter(|&&b| b).count();
    let intersection = rendered.iter().zip(&expected_cloth).filter(|(a, b)| **a && **b).count();
    let union = rendered.iter().zip(&expected_cloth).filter(|(a, b)| **a || **b).count();
    let iou = intersection as f64 / union as f64;
    let pixels = rendered.len();
    eprintln!(
        "cloth pixels: rendered {}, expected {}, IoU {iou:.4}; collider visible in {} px",
        count(&rendered),
        count(&expected_cloth),
        surfaces.iter().filter(|&&s| s == 2).count()
    );
    assert!(count(&expected_cloth) > pixels / 20, "the cloth fills a real part of the picture");
    assert!(surfaces.contains(&2), "the collider is in the picture too");
    assert!(iou >= 0.95, "IoU {iou:.4} between rendered and simulated cloth pixels");
}
