//! The model against the real host: its facts read once off the operating system ([`probe`]), the
//! host preset's costs fitted on microbenchmarks ([`calibrate`]) after the shared cache's usable
//! capacity is measured ([`shared_cache`]), and the model's predicted phase
//! times set against measured ones ([`validate`]). `machine/` itself never reads the OS or times
//! anything: it turns records and a configuration into time.

pub mod calibrate;
pub mod probe;
pub mod shared_cache;
pub mod validate;

use std::path::Path;
use std::sync::OnceLock;

use crate::machine::host::HostFacts;
use crate::machine::MachineConfig;

/// This host's facts, probed on the first call and kept for the process.
pub fn facts() -> &'static HostFacts {
    static FACTS: OnceLock<HostFacts> = OnceLock::new();
    FACTS.get_or_init(probe::probe)
}

/// A machine by preset name (`larrabee-24`, `host`, ...) or TOML file, the host's facts probed
/// only when the name or the file needs them (the `host` preset, a file based on it).
pub fn resolve_machine(preset_or_file: &str) -> crate::Result<MachineConfig> {
    let needs_host = preset_or_file == "host" || Path::new(preset_or_file).is_file();
    MachineConfig::resolve(preset_or_file, needs_host.then(facts))
}
