//! Frame traces: a scene moving over time (camera, light, per-mesh translations), rendered frame by
//! frame, and the flicker metric that compares an algorithm's frame-to-frame change with the
//! reference's.
//!
//! **Format** (text, one statement a line, `#` starts a comment):
//!
//! ```text
//! sism-trace 1
//! scene ../scenes/palm.toml          # relative to the trace file
//! frame                              # starts a frame; what it does not set carries over
//! camera 1100 1000 1500  0 450 100   # eye x y z, look_at x y z (world units)
//! fov 50                             # vertical field of view, degrees (optional)
//! light -1000 2600 -700  50          # centre x y z, radius (world units)
//! mesh 0 10 0 0                      # mesh index, translation x y z from its loaded place
//! ```
//!
//! The first frame starts from the scene file's camera and light; every later frame from the one
//! before it. [`write`] writes every field of every frame, so parse → write → parse is the identity.

use std::path::{Path, PathBuf};

use glam::Vec3;

pub mod run;

use crate::frame::VisibilityImage;
use crate::scene::Scene;

/// Most frames a trace may hold.
pub const MAX_FRAMES: usize = 100_000;
/// Largest |coordinate| accepted, world units (the scene file's bound).
const MAX_COORD: f32 = 1e15;
/// Most mesh moves a trace may hold, summed over its frames (each frame carries every move in force,
/// so a trace of 1 000 frames moving 1 000 meshes holds 10^6): bounds the memory a small file can ask
/// for (16 bytes a move).
pub const MAX_MOVES: usize = 4 << 20;
/// Highest mesh index a `mesh` statement may name (the scene's mesh count is checked when the trace
/// is applied; this bounds what a trace alone can ask for).
pub const MAX_MESH_INDEX: usize = 1 << 20;

/// One frame's view of the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceFrame {
    /// Eye position, world units.
    pub eye: Vec3,
    /// A point the camera looks at, world units.
    pub look_at: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    /// Light centre, world units.
    pub light_center: Vec3,
    /// Light radius, world units.
    pub light_radius: f32,
    /// `(mesh index, translation)` for each moved mesh, by index.
    pub mesh_moves: Vec<(usize, Vec3)>,
}

/// A trace: its scene file and its frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// The scene file, as written in the trace (relative to the trace's folder unless absolute).
    pub scene: PathBuf,
    /// The scene's origin ([`Scene::origin`]): the file holds world coordinates, the frames hold
    /// positions relative to this (converted in f64 when read and written).
    pub origin: [f64; 3],
    /// The frames, in order.
    pub frames: Vec<TraceFrame>,
}

/// A bad trace: where and what.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{path}:{line}: {message}")]
pub struct TraceError {
    /// The trace file.
    pub path: String,
    /// 1-based line number (0 for the file as a whole).
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// The first frame of a trace over `scene`: its camera and light, no mesh moved.
pub fn initial_frame(scene: &Scene) -> TraceFrame {
    TraceFrame {
        eye: Vec3::from(scene.camera.eye),
        look_at: Vec3::from(scene.camera.look_at),
        fov_y_deg: scene.camera.fov_y_deg,
        light_center: scene.light.center(),
        light_radius: scene.light.radius,
        mesh_moves: Vec::new(),
    }
}

/// Parses trace `text` (from `path`, for messages) over `scene`: frames start from its view
/// ([`initial_frame`]), positions are made relative to its origin.
pub fn parse_over(text: &str, path: &Path, scene: &Scene) -> Result<Trace, TraceError> {
    parse_at(text, path, &initial_frame(scene), scene.origin)
}

/// Parses trace `text` (from `path`, for messages) for a scene at the world origin. Frames start from
/// `start` (the scene's view: [`initial_frame`]); the scene line is returned as written.
pub fn parse(text: &str, path: &Path, start: &TraceFrame) -> Result<Trace, TraceError> {
    parse_at(text, path, start, [0.0; 3])
}

/// [`parse`] with positions made relative to `origin` (world units, f64).
fn parse_at(text: &str, path: &Path, start: &TraceFrame, origin: [f64; 3]) -> Result<Trace, TraceError> {
    let err = |line: usize, message: String| TraceError {
        path: path.display().to_string(),
        line,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    match lines.next() {
        Some((_, "sism-trace 1")) => {}
        Some((n, l)) => return Err(err(n, format!("expected the header `sism-trace 1`, found `{l}`"))),
        None => return Err(err(0, "empty trace: expected the header `sism-trace 1`".into())),
    }
    let mut scene = None;
    let mut frames: Vec<TraceFrame> = Vec::new();
    // The moves in force, by mesh index: set by `mesh` lines (a map, so many moves in one frame cost
    // n log n, not n²), copied into each frame when the next begins or the trace ends.
    let mut moves: std::collections::BTreeMap<usize, Vec3> = start.mesh_moves.iter().copied().collect();
    let mut total_moves = 0usize;
    for (n, line) in lines {
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or("");
        let rest: Vec<&str> = words.collect();
        let numbers = |count: usize| -> Result<Vec<f64>, TraceError> {
            if rest.len() != count {
                return Err(err(
                    n,
                    format!("`{key}` takes {count} numbers, found {}", rest.len()),
                ));
            }
            rest.iter()
                .map(|w| match w.parse::<f64>() {
                    Ok(v) if v.is_finite() && v.abs() <= MAX_COORD as f64 => Ok(v),
                    Ok(v) => Err(err(
                        n,
                        format!("`{key}`: {v} is not finite or beyond ±{MAX_COORD:e}"),
                    )),
                    Err(_) => Err(err(n, format!("`{key}`: `{w}` is not a number"))),
                })
                .collect()
        };
        if key == "scene" {
            if scene.is_some() || !frames.is_empty() {
                return Err(err(n, "`scene` must come once, before the first frame".into()));
            }
            // The path is the rest of the line (spaces allowed; `#` starts a comment, so a path
            // cannot hold one: [`write`] refuses such paths).
            let path = line["scene".len()..].trim();
            if path.is_empty() {
                return Err(err(n, "`scene` takes a path".into()));
            }
            scene = Some(PathBuf::from(path));
            continue;
        }
        if key == "frame" {
            if !rest.is_empty() {
                return Err(err(
                    n,
                    "`frame` takes nothing: its settings follow on their own lines".into(),
                ));
            }
            if frames.len() == MAX_FRAMES {
                return Err(err(n, format!("more than {MAX_FRAMES} frames")));
            }
            if let Some(f) = frames.last_mut() {
                f.mesh_moves = moves.iter().map(|(&i, &t)| (i, t)).collect();
            }
            total_moves += moves.len();
            if total_moves > MAX_MOVES {
                return Err(err(
                    n,
                    format!(
                        "the frames so far carry {total_moves} mesh moves (each frame every move in force); \
                         at most {MAX_MOVES} are accepted"
                    ),
                ));
            }
            let next = frames.last().cloned().unwrap_or_else(|| start.clone());
            frames.push(next);
            continue;
        }
        let Some(f) = frames.last_mut() else {
            return Err(err(n, format!("`{key}` before the first `frame`")));
        };
        match key {
            "camera" => {
                let v = numbers(6)?;
                let (eye, at) = (local(&v[0..3], origin), local(&v[3..6], origin));
                if eye == at {
                    return Err(err(n, "`camera`: the eye and the look-at point coincide".into()));
                }
                f.eye = eye;
                f.look_at = at;
            }
            "fov" => {
                let v = numbers(1)?[0] as f32;
                if !(v > 0.0 && v < 180.0) {
                    return Err(err(n, format!("`fov` {v}: degrees in (0, 180)")));
                }
                f.fov_y_deg = v;
            }
            "light" => {
                let v = numbers(4)?;
                if v[3] < 0.0 {
                    return Err(err(n, format!("`light` radius {} is negative", v[3])));
                }
                f.light_center = local(&v[0..3], origin);
                f.light_radius = v[3] as f32;
            }
            "mesh" => {
                let index: usize = rest
                    .first()
                    .and_then(|w| w.parse().ok())
                    .ok_or_else(|| err(n, "`mesh` takes a mesh index, then x y z".into()))?;
                if index > MAX_MESH_INDEX {
                    return Err(err(n, format!("`mesh` index {index} is beyond {MAX_MESH_INDEX}")));
                }
                let rest_xyz = &rest[1..];
                if rest_xyz.len() != 3 {
                    return Err(err(
                        n,
                        format!("`mesh` takes an index and 3 numbers, found {}", rest.len()),
                    ));
                }
                let mut v = [0f32; 3];
                for (k, w) in rest_xyz.iter().enumerate() {
                    v[k] = w
                        .parse::<f32>()
                        .ok()
                        .filter(|v| v.is_finite() && v.abs() <= MAX_COORD)
                        .ok_or_else(|| err(n, format!("`mesh`: `{w}` is not a finite number")))?;
                }
                moves.insert(index, Vec3::from(v));
            }
            _ => {
                return Err(err(
                    n,
                    format!("unknown statement `{key}` (expected scene, frame, camera, fov, light or mesh)"),
                ))
            }
        }
    }
    let scene = scene.ok_or_else(|| err(0, "no `scene` line".into()))?;
    let Some(last) = frames.last_mut() else {
        return Err(err(0, "no frames".into()));
    };
    last.mesh_moves = moves.iter().map(|(&i, &t)| (i, t)).collect();
    if total_moves + moves.len() > MAX_MOVES {
        return Err(err(
            0,
            format!("the frames carry more than {MAX_MOVES} mesh moves (each frame every move in force)"),
        ));
    }
    Ok(Trace {
        scene,
        origin,
        frames,
    })
}

/// A position read from a trace (world units, f64) relative to `origin`, as the frames hold it.
fn local(world: &[f64], origin: [f64; 3]) -> Vec3 {
    Vec3::new(
        (world[0] - origin[0]) as f32,
        (world[1] - origin[1]) as f32,
        (world[2] - origin[2]) as f32,
    )
}

/// A frame's position back in world units, as the trace file holds it. At the world origin the f32
/// value itself (written as f32, its shortest form); elsewhere the f64 sum.
fn world(local: Vec3, origin: [f64; 3]) -> [String; 3] {
    let mut out = [String::new(), String::new(), String::new()];
    for (k, o) in out.iter_mut().enumerate() {
        *o = if origin == [0.0; 3] {
            local[k].to_string()
        } else {
            (local[k] as f64 + origin[k]).to_string()
        };
    }
    out
}

/// The scene path as a trace's `scene` line holds it: UTF-8, not empty, no `#`, no control
/// character, no space at either end (else the line would not read back as the same path).
fn scene_line(scene: &Path) -> Result<&str, String> {
    let text = scene.to_str().ok_or_else(|| {
        format!(
            "scene path {}: not UTF-8, which a trace file cannot hold",
            scene.display()
        )
    })?;
    if text.is_empty() || text.contains('#') || text.chars().any(char::is_control) || text.trim() != text {
        return Err(format!(
            "scene path {text:?}: a trace names its scene on one line, so the path cannot hold `#` (a comment), \
             a control character or a space at either end; move or rename the scene"
        ));
    }
    Ok(text)
}

/// The trace as text: every field of every frame. Its scene path must read back: UTF-8, no `#`, no
/// control character, no space at either end; anything else is an error naming it.
pub fn write(trace: &Trace) -> Result<String, String> {
    let scene = scene_line(&trace.scene)?;
    let mut s = format!("sism-trace 1\nscene {scene}\n");
    for f in &trace.frames {
        let [ex, ey, ez] = world(f.eye, trace.origin);
        let [ax, ay, az] = world(f.look_at, trace.origin);
        let [lx, ly, lz] = world(f.light_center, trace.origin);
        s += &format!(
            "frame\ncamera {ex} {ey} {ez}  {ax} {ay} {az}\nfov {}\nlight {lx} {ly} {lz}  {}\n",
            f.fov_y_deg, f.light_radius
        );
        for (i, t) in &f.mesh_moves {
            s += &format!("mesh {i} {} {} {}\n", t.x, t.y, t.z);
        }
    }
    Ok(s)
}

/// Checks that every frame of `trace` can be rendered over `scene`: finite positions within the
/// format's bound, a camera the scene's rules accept (eye apart from the look-at point, field of view
/// in range), a light radius that is finite and not negative, mesh indices the scene has, and a
/// scene path a trace file can hold. The error names the frame (0-based) and what is wrong.
pub fn check(trace: &Trace, scene: &Scene) -> Result<(), String> {
    scene_line(&trace.scene)?;
    let mut camera = scene.camera;
    for (k, f) in trace.frames.iter().enumerate() {
        let numbers = [f.eye, f.look_at, f.light_center]
            .into_iter()
            .flat_map(|v| v.to_array())
            .chain([f.fov_y_deg, f.light_radius])
            .chain(f.mesh_moves.iter().flat_map(|m| m.1.to_array()));
        for v in numbers {
            if !(v.is_finite() && v.abs() <= MAX_COORD) {
                return Err(format!("frame {k}: {v} is not finite or beyond ±{MAX_COORD:e}"));
            }
        }
        if f.light_radius < 0.0 {
            return Err(format!("frame {k}: light radius {} is negative", f.light_radius));
        }
        camera.eye = f.eye.to_array();
        camera.look_at = f.look_at.to_array();
        camera.fov_y_deg = f.fov_y_deg;
        if let Err((key, msg)) = camera.validate() {
            return Err(format!("frame {k}: {key} {msg}"));
        }
        if let Some((i, _)) = f.mesh_moves.iter().find(|m| m.0 >= scene.meshes.len()) {
            return Err(format!(
                "frame {k}: mesh {i}: the scene has {} meshes",
                scene.meshes.len()
            ));
        }
    }
    Ok(())
}

/// `base` as frame `f` sees it: camera, light, and the moved meshes translated. Errors name a mesh
/// index the scene does not have.
pub fn apply(base: &Scene, f: &TraceFrame) -> Result<Scene, String> {
    let mut s = base.clone();
    apply_to(&mut s, base, f, true)?;
    Ok(s)
}

/// Sets `scene` (a copy of `base`) to frame `f`: its camera and light always; its meshes, as `base`'s
/// translated by the frame's moves, only when `geometry` is set (the moves differ from the frame
/// `scene` last showed), so a frame that moves no mesh copies no geometry.
pub fn apply_to(scene: &mut Scene, base: &Scene, f: &TraceFrame, geometry: bool) -> Result<(), String> {
    scene.camera.eye = f.eye.to_array();
    scene.camera.look_at = f.look_at.to_array();
    scene.camera.fov_y_deg = f.fov_y_deg;
    scene.light.center = f.light_center.to_array();
    scene.light.radius = f.light_radius;
    if geometry {
        for (m, b) in scene.meshes.iter_mut().zip(&base.meshes) {
            m.positions.copy_from_slice(&b.positions);
        }
        for &(i, t) in &f.mesh_moves {
            let m = scene
                .meshes
                .get_mut(i)
                .ok_or_else(|| format!("mesh {i}: the scene has {} meshes", base.meshes.len()))?;
            m.positions.iter_mut().for_each(|p| *p += t);
        }
    }
    if let Err((key, msg)) = scene.camera.validate() {
        return Err(format!("{key} {msg}"));
    }
    Ok(())
}

/// `frames` frames (at least 1) from `scene`'s own view, frame `k` being `step(first, share)` where
/// `share(x)` is `x · k / (frames − 1)`: the part of a total `x` done by frame `k`.
fn sweep(
    scene_file: &Path,
    scene: &Scene,
    frames: usize,
    step: impl Fn(&TraceFrame, &dyn Fn(f32) -> f32) -> TraceFrame,
) -> Trace {
    let f0 = initial_frame(scene);
    let last = frames.max(2).saturating_sub(1) as f32;
    Trace {
        scene: scene_file.to_path_buf(),
        origin: scene.origin,
        frames: (0..frames.max(1))
            .map(|k| step(&f0, &|x| x * k as f32 / last))
            .collect(),
    }
}

/// A camera orbit: `frames` frames turning the eye about the vertical axis through the look-at
/// point by `degrees` in all.
pub fn orbit(scene_file: &Path, scene: &Scene, frames: usize, degrees: f32) -> Trace {
    sweep(scene_file, scene, frames, |f0, share| TraceFrame {
        eye: f0.look_at + glam::Quat::from_rotation_y(share(degrees).to_radians()) * (f0.eye - f0.look_at),
        ..f0.clone()
    })
}

/// A walk-through: `frames` frames moving the eye and its look-at point together along the view
/// direction by `share` of the eye's distance to the look-at point in all.
pub fn walk(scene_file: &Path, scene: &Scene, frames: usize, share: f32) -> Trace {
    sweep(scene_file, scene, frames, |f0, done| {
        let moved = (f0.look_at - f0.eye) * share * done(1.0);
        TraceFrame {
            eye: f0.eye + moved,
            look_at: f0.look_at + moved,
            ..f0.clone()
        }
    })
}

/// A light sweep: `frames` frames turning the light's centre about the vertical axis through the
/// camera's look-at point by `degrees` in all.
pub fn light_sweep(scene_file: &Path, scene: &Scene, frames: usize, degrees: f32) -> Trace {
    sweep(scene_file, scene, frames, |f0, share| TraceFrame {
        light_center: f0.look_at
            + glam::Quat::from_rotation_y(share(degrees).to_radians()) * (f0.light_center - f0.look_at),
        ..f0.clone()
    })
}

/// Flicker between two consecutive frames, per pixel `|(V_t − V_{t−1}) − (R_t − R_{t−1})|` over the
/// pixels that are receivers (V in [0, 1]) in all four images; the reference's change is 0 when
/// `reference` is `None` (then it is the algorithm's own frame-to-frame change). Returns the values.
pub fn flicker_values(
    prev: &VisibilityImage,
    cur: &VisibilityImage,
    reference: Option<(&VisibilityImage, &VisibilityImage)>,
) -> Vec<f32> {
    let ok = |v: f32| (0.0..=1.0).contains(&v);
    (0..cur.values.len().min(prev.values.len()))
        .filter_map(|k| {
            let (a, b) = (prev.values[k], cur.values[k]);
            if !ok(a) || !ok(b) {
                return None;
            }
            let d_ref = match reference {
                Some((rp, rc)) => {
                    let (x, y) = (*rp.values.get(k)?, *rc.values.get(k)?);
                    if !ok(x) || !ok(y) {
                        return None;
                    }
                    y - x
                }
                None => 0.0,
            };
            Some(((b - a) - d_ref).abs())
        })
        .collect()
}

/// Mean and 99th percentile (nearest rank) of `values`; zeros when empty.
pub fn summarize(values: &mut [f32]) -> (f64, f64) {
    if values.is_empty() {
        return (0.0, 0.0);
    }
    let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64;
    values.sort_by(f32::total_cmp);
    let rank = ((0.99 * values.len() as f64).ceil() as usize).clamp(1, values.len());
    (mean, values[rank - 1] as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start() -> TraceFrame {
        TraceFrame {
            eye: Vec3::new(0.0, 2.0, 4.0),
            look_at: Vec3::ZERO,
            fov_y_deg: 45.0,
            light_center: Vec3::new(0.0, 4.0, 0.0),
            light_radius: 0.3,
            mesh_moves: Vec::new(),
        }
    }

    #[test]
    fn round_trips_and_carries_settings_over() {
        let text = "sism-trace 1\n# a comment\nscene ../scenes/plate.toml\nframe\ncamera 1 2 3  0 0 0.5\n\
                    frame\nlight 1 5 -1 0.25 # trailing comment\nmesh 1 0.5 0 0\nmesh 0 0 1e-3 0\nframe\nfov 30\n";
        let t = parse(text, Path::new("t.trace"), &start()).unwrap();
        assert_eq!(t.frames.len(), 3);
        assert_eq!(t.frames[1].eye, Vec3::new(1.0, 2.0, 3.0)); // carried over
        assert_eq!(t.frames[1].light_radius, 0.25);
        assert_eq!(
            t.frames[2].mesh_moves,
            vec![(0, Vec3::new(0.0, 1e-3, 0.0)), (1, Vec3::new(0.5, 0.0, 0.0))]
        );
        assert_eq!(t.frames[2].fov_y_deg, 30.0);
        let again = parse(&write(&t).unwrap(), Path::new("t.trace"), &start()).unwrap();
        assert_eq!(again, t);
        // Odd values survive the text too.
        let mut odd = t.clone();
        odd.frames[0].eye.x = 0.1 + 0.2;
        odd.frames[0].light_center.z = -1.0e-7;
        assert_eq!(
            parse(&write(&odd).unwrap(), Path::new("t"), &start()).unwrap(),
            odd
        );
    }

    #[test]
    fn bad_traces_name_the_line() {
        for (text, line, needle) in [
            ("", 0, "header"),
            ("sism trace\n", 1, "header"),
            ("sism-trace 1\nframe\n", 0, "scene"),
            ("sism-trace 1\nscene a.toml\n", 0, "no frames"),
            (
                "sism-trace 1\nscene a.toml\ncamera 1 2 3 4 5 6\n",
                3,
                "before the first",
            ),
            (
                "sism-trace 1\nscene a.toml\nframe\ncamera 1 2 3 4 5\n",
                4,
                "6 numbers",
            ),
            (
                "sism-trace 1\nscene a.toml\nframe\n\ncamera 1 2 x 4 5 6\n",
                5,
                "`x` is not a number",
            ),
            (
                "sism-trace 1\nscene a.toml\nframe\nlight 0 0 0 NaN\n",
                4,
                "not finite",
            ),
            (
                "sism-trace 1\nscene a.toml\nframe\nlight 0 0 0 -1\n",
                4,
                "negative",
            ),
            ("sism-trace 1\nscene a.toml\nframe\nfov 180\n", 4, "(0, 180)"),
            (
                "sism-trace 1\nscene a.toml\nframe\ncamera 1 1 1 1 1 1\n",
                4,
                "coincide",
            ),
            (
                "sism-trace 1\nscene a.toml\nframe\nmesh x 1 2 3\n",
                4,
                "mesh index",
            ),
            (
                "sism-trace 1\nscene a.toml\nframe\nspin 3\n",
                4,
                "unknown statement",
            ),
            ("sism-trace 1\nscene a.toml\nframe 2\n", 3, "takes nothing"),
            ("sism-trace 1\nframe\nscene a.toml\n", 3, "before the first frame"),
        ] {
            let e = parse(text, Path::new("bad.trace"), &start()).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e}");
            assert!(
                e.to_string().contains(needle) && e.to_string().starts_with("bad.trace:"),
                "{text:?}: {e}"
            );
        }
    }

    #[test]
    fn identical_frames_have_zero_flicker() {
        let img = VisibilityImage {
            width: 2,
            height: 2,
            values: vec![0.25, f32::NAN, 1.0, -1.0],
        };
        let mut v = flicker_values(&img, &img, Some((&img, &img)));
        assert_eq!(v.len(), 2);
        assert_eq!(summarize(&mut v), (0.0, 0.0));
        let moved = VisibilityImage {
            values: vec![0.75, f32::NAN, 1.0, -1.0],
            ..img.clone()
        };
        // The algorithm changes where the reference does not: flicker 0.5 at that pixel.
        let mut v = flicker_values(&img, &moved, Some((&img, &img)));
        assert_eq!(summarize(&mut v), (0.25, 0.5));
        // The same change in both: no flicker.
        let mut v = flicker_values(&img, &moved, Some((&img, &moved)));
        assert_eq!(summarize(&mut v).0, 0.0);
    }
}
