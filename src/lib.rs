//! sism: soft irregular shadow mapping (Johnson et al., I3D 2009) and the other soft-shadow methods on
//! a modelled 16-wide SIMD many-core machine, with a ray-traced reference and error metrics. See
//! ARCHITECTURE.md for the design.
//!
//! Layers, bottom up (a module uses only those above it in this list):
//! `stats`, `exec`, `vmath` (with the `sism-simd` crate) → `scene`, `frame`, `sampling`, `bvh` →
//! `raster` → `algorithms` (the registry, the reference, SISM) → `machine` (records → time; it uses
//! only `exec`'s records and `stats`) → `render`, `bench`, `metrics`, `output`, `validate` (the model against the host). The command line
//! lives in the binary (`src/cli/`); nothing here names a flag.

#![deny(unsafe_op_in_unsafe_fn)]

pub mod algorithms;
pub mod bench;
pub mod bvh;
pub mod error;
pub mod exec;
pub mod frame;
pub mod input;
pub mod machine;
pub mod metrics;
pub mod output;
pub mod progress;
pub mod raster;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod stats;
pub mod table2;
pub mod trace;
pub mod validate;
pub mod vmath;
