//! A reproducible stream of floats for the kernels' unit tests (xorshift64).

/// Floats in [0, 1) from `seed` (not 0), the same stream on every run.
pub(crate) fn unit_floats(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}
