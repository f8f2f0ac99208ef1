//! sism: soft irregular shadow mapping (Johnson et al., I3D 2009) and the other soft-shadow methods on
//! a modelled 16-wide SIMD many-core machine, with a ray-traced reference and error metrics.
//!
//! The modules and their layers are listed in ARCHITECTURE.md ("Workspace and layers"); that list
//! is the one kept true. The command line is another crate (`sism-cli`): nothing here parses a flag
//! or draws a terminal bar.
//!
//! A scene from the caller's own arrays, rendered with a named algorithm natively and on a modelled
//! chip, and compared with the ray-traced reference:
//!
//! ```
//! use sism::{Camera, Light, MachineConfig, Mesh, Scene};
//! use sism::render::{render, render_on_machine, RenderOptions};
//!
//! # fn main() -> Result<(), sism::Error> {
//! // A plate over a ground plane, lit from above (world units).
//! let v = |x: f32, y: f32, z: f32| glam::Vec3::new(x, y, z);
//! let ground = Mesh {
//!     name: "ground".into(),
//!     positions: vec![v(-4.0, 0.0, -4.0), v(4.0, 0.0, -4.0), v(4.0, 0.0, 4.0), v(-4.0, 0.0, 4.0)],
//!     triangles: vec![[0, 2, 1], [0, 3, 2]],
//! };
//! let plate = Mesh {
//!     name: "plate".into(),
//!     positions: vec![v(-1.0, 1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(-1.0, 1.0, 1.0)],
//!     triangles: vec![[0, 2, 1], [0, 3, 2]],
//! };
//! let camera = Camera {
//!     eye: [0.0, 5.0, 7.0],
//!     look_at: [0.0, 0.0, 0.0],
//!     up: [0.0, 1.0, 0.0],
//!     fov_y_deg: 45.0,
//!     width: 48,
//!     height: 36,
//! };
//! let light = Light { center: [0.0, 5.0, 0.0], radius: 0.5 };
//! let scene = Scene::from_meshes("plate-in-code", vec![ground, plate], camera, light)?;
//!
//! // `sism-sampled` natively: its visibility and counters.
//! let algo = sism::algorithms::find("sism-sampled").expect("registered");
//! let params = algo.params(&[])?;
//! let native = render(&scene, algo, &params, &RenderOptions::default());
//!
//! // The same frame counted and timed on the paper's 24-core Larrabee.
//! let chip = MachineConfig::preset("larrabee-24").expect("a preset");
//! let timed = render_on_machine(&scene, algo, &params, &chip, false);
//! assert!(timed.report.frame.ms > 0.0);
//!
//! // The ray-traced reference (64 light samples per receiver) and the error against it.
//! let reference = sism::algorithms::find("reference").expect("registered");
//! let spp = reference.params(&[("spp".into(), "64".into())])?;
//! let truth = render(&scene, reference, &spp, &RenderOptions::default());
//! let error = sism::metrics::compare(&truth.visibility, &native.visibility)?;
//! assert!(error.mae < 0.05, "MAE {}", error.mae);
//! # Ok(())
//! # }
//! ```

#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod algorithms;
pub mod bench;
pub mod bvh;
pub mod counted;
pub mod error;
pub mod exec;
pub mod frame;
pub mod host;
pub mod input;
pub mod machine;
pub mod metrics;
pub mod output;
pub mod perceptual;
pub mod progress;
pub mod raster;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod stats;
pub mod study;
pub mod table2;
pub mod trace;
pub mod vmath;

pub use algorithms::{Algorithm, Params};
pub use error::{Context, Error, ErrorKind, InputError, Result};
pub use frame::VisibilityImage;
pub use machine::MachineConfig;
pub use metrics::ErrorReport;
pub use scene::{Camera, Light, Mesh, Scene};
