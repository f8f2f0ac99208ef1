//! Files a render writes (CONTRACTS.md "Images written by a render") and reads back. The statistics'
//! files are written by [`crate::stats::StatsReport::write`].

pub mod pfm;
pub mod pictures;
