//! Soft irregular shadow mapping (Johnson et al., I3D 2009), one module per stage of the algorithm.
//! Every kernel is written once against `sism_simd` and runs natively (AVX-512 or portable) or under
//! the counting context.

pub mod eye_pass;
pub mod occlusion;
