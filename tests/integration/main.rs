//! sism's integration tests: one binary, a module per feature (ripgrep's layout, so the crate links once).

mod bad_input;
mod beams;
mod closed_forms;
mod convergence;
mod declared_work;
mod docs;
mod formats;
mod gaussian;
mod golden;
mod hardening;
mod host_model;
mod inlining;
mod multi_sample;
mod obj_loading;
mod rbsm;
mod registry;
mod report_html;
mod shadow_maps;
mod shared_scenes;
mod sism;
mod ssmm;
mod study_slurm;
mod study_sweep;
mod surfaces;
mod util;
mod workloads;
