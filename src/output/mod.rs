//! Files a render writes (CONTRACTS.md "Images written by a render") and reads back.

pub mod pfm;
pub mod pictures;
pub mod plot;
pub mod stats;
