//! sism: soft irregular shadow mapping (Johnson et al., I3D 2009) on a modelled 16-wide SIMD many-core
//! machine, with a ray-traced reference and error metrics. See ARCHITECTURE.md for the design.

pub mod bench_cmd;
pub mod bvh;
pub mod error;
pub mod frame;
pub mod machine;
pub mod metrics;
pub mod output;
pub mod progress;
pub mod reference;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod sism;
