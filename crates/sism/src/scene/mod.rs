//! Scenes: the TOML scene file of CONTRACTS.md, its meshes, camera and spherical light.
//!
//! A file with only the contract's keys always loads; the optional extras are per-mesh transforms and
//! inline shapes (`[[quad]]`, `[[box]]`, `[[sphere]]`, `[[disk]]`). Unknown keys are errors that name the
//! key (serde's `deny_unknown_fields`), and every value is checked before anything is rendered.

mod obj;
pub mod shapes;
pub mod topology;

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;

use crate::error::InputError;
pub use obj::load_obj;

/// Largest accepted image side, pixels. Beyond it an image is surely a typo.
pub const MAX_IMAGE_SIDE: u32 = 32_768;
/// Largest accepted pixel count (2^27 = 134M pixels). Every algorithm keeps tens of bytes per pixel
/// (receiver position, normal, visibility, sample records); past this a frame needs several GiB and
/// would not fit in the 24 GiB machines this project runs on once the algorithms' buffers are added.
pub const MAX_PIXELS: u64 = 1 << 27;
/// Largest accepted |coordinate| of any point of a scene (vertices after their mesh's transform,
/// shape corners, camera, light centre) and of any size (radii), world units. Squares of such values
/// stay finite in f32 (1e30 < 3.4e38), so every normalisation and cross product downstream stays
/// finite; the ray tracer's BVH build fails on coordinates past ~1e18.
pub const MAX_COORDINATE: f32 = 1e15;
/// Largest accepted triangle count of a scene (2^27): triangle indices and the rasterizer's packed
/// ids are 32-bit, and every algorithm keeps tens of bytes per triangle.
pub const MAX_TRIANGLES: usize = 1 << 27;
/// A scene is rebased ([`Scene::origin`]) when its camera's look-at point is further from the world
/// origin than this many times the eye's distance to it: f32 keeps about 7 digits, so a scene a few
/// hundred thousand units from the origin but a few units across would otherwise lose its detail
/// to rounding (and every offset scaled by coordinates' magnitudes would swamp it).
pub const REBASE_FACTOR: f64 = 16.0;

/// Field of view bounds, degrees: narrower or wider views have no usable projection in f32.
pub const FOV_RANGE_DEG: (f32, f32) = (1e-3, 179.999);

/// One triangle mesh with shared vertices (shared so edge adjacency, and with it silhouettes, can be
/// found later). Positions are in world units after the mesh's transform.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name for messages and statistics (the OBJ file stem or the shape's kind).
    pub name: String,
    /// Vertex positions, world space.
    pub positions: Vec<Vec3>,
    /// Triangles as indices into `positions`, counter-clockwise as given by the file.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }
}

/// The pinhole camera of CONTRACTS.md.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Eye position, world units.
    #[serde(deserialize_with = "xyz")]
    pub eye: [f32; 3],
    /// A point the camera looks at; must differ from `eye`.
    #[serde(deserialize_with = "xyz")]
    pub look_at: [f32; 3],
    /// Up direction (need not be unit; not parallel to the view direction). Default +y.
    #[serde(default = "default_up", deserialize_with = "xyz")]
    pub up: [f32; 3],
    /// Vertical field of view, degrees, in (0, 180).
    pub fov_y_deg: f32,
    /// Image width, pixels, 1..=[`MAX_IMAGE_SIDE`].
    pub width: u32,
    /// Image height, pixels, 1..=[`MAX_IMAGE_SIDE`].
    pub height: u32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// The camera's orthonormal frame, derived once: `d(i, j)` per CONTRACTS.md.
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    /// Eye position, world units.
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit image-plane right direction.
    pub right: Vec3,
    /// Unit image-plane up direction, orthogonal to `forward` and `right`.
    pub up: Vec3,
    /// `tan(fov_y / 2)`.
    pub tan_half_fov: f32,
    /// `width / height`.
    pub aspect: f32,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

impl Camera {
    /// Checks the camera; the error is `(key, message)` for [`InputError::InvalidValue`].
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (key, v) in [
            ("camera.eye", self.eye),
            ("camera.look_at", self.look_at),
            ("camera.up", self.up),
        ] {
            check_finite(key, v)?;
        }
        let (lo, hi) = FOV_RANGE_DEG;
        if !(self.fov_y_deg.is_finite() && self.fov_y_deg >= lo && self.fov_y_deg <= hi) {
            return Err((
                "camera.fov_y_deg",
                format!("is {}, must be in [{lo}, {hi}] degrees", self.fov_y_deg),
            ));
        }
        for (key, side) in [("camera.width", self.width), ("camera.height", self.height)] {
            if side == 0 || side > MAX_IMAGE_SIDE {
                return Err((key, format!("is {side}, must be in 1..={MAX_IMAGE_SIDE} pixels")));
            }
        }
        let pixels = self.width as u64 * self.height as u64;
        if pixels > MAX_PIXELS {
            return Err((
                "camera.width",
                format!(
                    "{}x{} is {pixels} pixels; at most {MAX_PIXELS} fit the frame buffers in memory",
                    self.width, self.height
                ),
            ));
        }
        let view = Vec3::from(self.look_at) - Vec3::from(self.eye);
        let scale = Vec3::from(self.eye).abs().max_element().max(1.0);
        if view.length() <= 1e-6 * scale {
            return Err((
                "camera.look_at",
                "equals camera.eye: the view direction is undefined".into(),
            ));
        }
        let up = Vec3::from(self.up);
        if up.length() == 0.0 || view.normalize().cross(up.normalize()).length() < 1e-4 {
            return Err((
                "camera.up",
                "is zero or parallel to the view direction (look_at - eye)".into(),
            ));
        }
        Ok(())
    }

    /// The camera frame. Call on a validated camera.
    pub fn frame(&self) -> CameraFrame {
        let eye = Vec3::from(self.eye);
        let forward = (Vec3::from(self.look_at) - eye).normalize();
        let right = forward.cross(Vec3::from(self.up)).normalize();
        let up = right.cross(forward);
        CameraFrame {
            eye,
            forward,
            right,
            up,
            tan_half_fov: (self.fov_y_deg.to_radians() * 0.5).tan(),
            aspect: self.width as f32 / self.height as f32,
            width: self.width,
            height: self.height,
        }
    }
}

impl CameraFrame {
    /// Unit direction of the ray through the centre of pixel column `i` (0 = left), row `j` (0 = top).
    #[inline]
    pub fn ray_direction(&self, i: u32, j: u32) -> Vec3 {
        let sx = (2.0 * (i as f32 + 0.5) / self.width as f32 - 1.0) * self.tan_half_fov * self.aspect;
        let sy = (1.0 - 2.0 * (j as f32 + 0.5) / self.height as f32) * self.tan_half_fov;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }
}

/// The spherical light: seen from a receiver, a disk of `radius` centred at `center`, perpendicular to the
/// direction towards the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Light {
    /// Centre, world units.
    #[serde(deserialize_with = "xyz")]
    pub center: [f32; 3],
    /// Radius, world units, >= 0; 0 is a point light (hard shadows).
    pub radius: f32,
}

impl Light {
    /// Centre as a vector.
    pub fn center(&self) -> Vec3 {
        Vec3::from(self.center)
    }
}

/// A scene ready to render: meshes, camera and light, in world units relative to [`Scene::origin`].
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file it came from (for messages and statistics).
    pub source: PathBuf,
    /// Where the scene's coordinates start, in the file's world coordinates: `[0, 0, 0]` for most
    /// scenes; the camera's look-at point for a scene viewed far from the world origin (beyond
    /// [`REBASE_FACTOR`] times the viewing distance). Every position below is `world − origin`,
    /// computed in f64 from the file's values before rounding to f32, so a scene keeps its detail
    /// wherever it sits. Visibility does not depend on it.
    pub origin: [f64; 3],
    /// The meshes, in world units relative to `origin`.
    pub meshes: Vec<Mesh>,
    /// The camera.
    pub camera: Camera,
    /// The light.
    pub light: Light,
}

impl Scene {
    /// Loads and checks the scene file at `path`, and every mesh it names (relative to its folder).
    pub fn load(path: &Path) -> Result<Scene, InputError> {
        let text = crate::input::read_text(path, "scene file", crate::input::MAX_TEXT_BYTES)?;
        Self::from_toml(&text, path)
    }

    /// Parses scene TOML `text` as if read from `path` (meshes resolve relative to its folder).
    pub fn from_toml(text: &str, path: &Path) -> Result<Scene, InputError> {
        let toml_error = |e: toml::de::Error| InputError::Toml {
            path: path.into(),
            message: e.to_string().trim_end().to_string(),
        };
        // Parsed as written first, so every error carries its line and column.
        let file: SceneFile = toml::from_str(text).map_err(toml_error)?;
        let Some(origin) = rebase_origin(&file.camera) else {
            return file.build(path, [0.0; 3]);
        };
        // Far from the origin: every absolute position moved by −origin in f64, then read as f32.
        let mut table: toml::Table = toml::from_str(text).map_err(toml_error)?;
        rebase_table(&mut table, origin);
        let file = SceneFile::deserialize(toml::Value::Table(table)).map_err(toml_error)?;
        file.build(path, origin)
    }

    /// A scene built in code from the caller's own geometry (an engine has its meshes in memory, not
    /// in TOML): `meshes` in world units, the camera and the light as the scene file states them.
    /// Checked as a file is: the camera and light (CONTRACTS.md's ranges), every position finite and
    /// within ±[`MAX_COORDINATE`], every index inside its mesh, at least one triangle and at most
    /// [`MAX_TRIANGLES`]. `name` stands for the file in messages, studies and plots.
    pub fn from_meshes(
        name: &str,
        meshes: Vec<Mesh>,
        camera: Camera,
        light: Light,
    ) -> Result<Scene, InputError> {
        let path = PathBuf::from(name);
        let invalid = |key: String, message: String| InputError::InvalidValue {
            path: path.clone(),
            key,
            message,
        };
        camera.validate().map_err(|(k, m)| invalid(k.to_string(), m))?;
        check_finite("light.center", light.center).map_err(|(k, m)| invalid(k.to_string(), m))?;
        check_size(light.radius, true)
            .map_err(|m| invalid("light.radius".into(), format!("{m} (0 is a point light)")))?;
        let mut total = 0usize;
        for (i, mesh) in meshes.iter().enumerate() {
            check_positions(mesh, "as given").map_err(|m| invalid(format!("mesh[{i}].positions"), m))?;
            let n = mesh.positions.len();
            if let Some((t, tri)) = mesh
                .triangles
                .iter()
                .enumerate()
                .find(|(_, tri)| tri.iter().any(|&v| v as usize >= n))
            {
                return Err(invalid(
                    format!("mesh[{i}].triangles"),
                    format!("triangle {t} is {tri:?}: an index is not below the mesh's {n} positions"),
                ));
            }
            total = total.saturating_add(mesh.triangles.len());
        }
        if total == 0 {
            return Err(invalid("mesh".into(), "the scene has no triangle".into()));
        }
        if total > MAX_TRIANGLES {
            return Err(invalid(
                "mesh".into(),
                format!("the scene has {total} triangles; at most {MAX_TRIANGLES} are accepted"),
            ));
        }
        Ok(Scene {
            source: path,
            origin: [0.0; 3],
            meshes,
            camera,
            light,
        })
    }

    /// Total triangle count over all meshes.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.triangles.len()).sum()
    }

    /// Every triangle's corners, mesh by mesh, in file order.
    pub fn triangles(&self) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        self.meshes
            .iter()
            .flat_map(|m| (0..m.triangles.len()).map(move |t| m.corners(t)))
    }

    /// Axis-aligned bounds of all geometry, `(min, max)`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.meshes
            .iter()
            .flat_map(|m| m.positions.iter())
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            })
    }
}

// ---------------------------------------------------------------------------------------------------
// The file format. Kept private: the rest of sism sees only `Scene`.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    mesh: Vec<MeshEntry>,
    #[serde(default)]
    quad: Vec<QuadEntry>,
    #[serde(default, rename = "box")]
    boxes: Vec<BoxEntry>,
    #[serde(default)]
    sphere: Vec<SphereEntry>,
    #[serde(default)]
    disk: Vec<DiskEntry>,
    camera: Camera,
    light: Light,
}

/// `[[mesh]]`: an OBJ file and an optional transform `translate + rotate_y(scale * p)`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshEntry {
    path: PathBuf,
    #[serde(default = "one")]
    scale: f32,
    #[serde(default)]
    rotate_y_deg: f32,
    #[serde(default, deserialize_with = "xyz")]
    translate: [f32; 3],
}

fn one() -> f32 {
    1.0
}

/// `[[quad]]`: the parallelogram `corner + s*edge_u + t*edge_v`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct QuadEntry {
    #[serde(deserialize_with = "xyz")]
    corner: [f32; 3],
    #[serde(deserialize_with = "xyz")]
    edge_u: [f32; 3],
    #[serde(deserialize_with = "xyz")]
    edge_v: [f32; 3],
}

/// `[[box]]`: an axis-aligned box.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoxEntry {
    #[serde(deserialize_with = "xyz")]
    min: [f32; 3],
    #[serde(deserialize_with = "xyz")]
    max: [f32; 3],
}

/// `[[sphere]]`: a UV sphere, `segments` around (3..=1024, default 48).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereEntry {
    #[serde(deserialize_with = "xyz")]
    center: [f32; 3],
    radius: f32,
    #[serde(default = "default_segments")]
    segments: u32,
}

/// `[[disk]]`: a regular polygon inscribed in a circle (3..=65536 `segments`, default 48).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DiskEntry {
    #[serde(deserialize_with = "xyz")]
    center: [f32; 3],
    #[serde(deserialize_with = "xyz")]
    normal: [f32; 3],
    radius: f32,
    #[serde(default = "default_segments")]
    segments: u32,
}

fn default_segments() -> u32 {
    48
}

/// A 3-vector key: exactly three numbers (serde would accept a longer array and drop the rest).
fn xyz<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    let v: Vec<f32> = Vec::deserialize(d)?;
    <[f32; 3]>::try_from(v.as_slice()).map_err(|_| {
        serde::de::Error::custom(format!("expected 3 numbers [x, y, z], found {} numbers", v.len()))
    })
}

/// Every coordinate finite and within [`MAX_COORDINATE`].
fn check_finite(key: &'static str, v: [f32; 3]) -> Result<(), (&'static str, String)> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORDINATE) {
        Ok(())
    } else {
        Err((
            key,
            format!("is {v:?}: every coordinate must be finite and within ±{MAX_COORDINATE:e}"),
        ))
    }
}

/// A direction (a normal, an edge vector): finite, and within `2 ×` [`MAX_COORDINATE`] for edges
/// (the corners it reaches are checked on their own); normals of any finite length are scaled.
fn check_direction(v: [f32; 3], limit: f32) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= limit) {
        Ok(())
    } else {
        Err(format!(
            "is {v:?}: every component must be finite and within ±{limit:e}"
        ))
    }
}

/// A size (radius) finite, > 0 (or >= 0 with `zero_ok`) and within [`MAX_COORDINATE`].
fn check_size(value: f32, zero_ok: bool) -> Result<(), String> {
    let low_ok = if zero_ok { value >= 0.0 } else { value > 0.0 };
    if value.is_finite() && low_ok && value <= MAX_COORDINATE {
        Ok(())
    } else {
        Err(format!(
            "is {value}, must be finite, {} and at most {MAX_COORDINATE:e}",
            if zero_ok { ">= 0" } else { "> 0" }
        ))
    }
}

/// Every vertex of `mesh` finite and within [`MAX_COORDINATE`]: the error names the vertex and where
/// it came from (`origin`: the transform or shape that made it).
fn check_positions(mesh: &Mesh, origin: &str) -> Result<(), String> {
    match mesh
        .positions
        .iter()
        .position(|p| !(p.is_finite() && p.abs().max_element() <= MAX_COORDINATE))
    {
        None => Ok(()),
        Some(k) => Err(format!(
            "makes vertex {k} {} ({origin}): every coordinate must be finite and within ±{MAX_COORDINATE:e}",
            mesh.positions[k]
        )),
    }
}

/// The origin a scene viewed by `camera` is rebased to ([`Scene::origin`]), if it needs one.
fn rebase_origin(camera: &Camera) -> Option<[f64; 3]> {
    let at = camera.look_at.map(f64::from);
    let eye = camera.eye.map(f64::from);
    let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let view = norm([eye[0] - at[0], eye[1] - at[1], eye[2] - at[2]]);
    (view > 0.0 && norm(at) > REBASE_FACTOR * view).then_some(at)
}

/// The keys of a scene file that hold absolute positions (not sizes or directions), by table.
const POSITION_KEYS: [(&str, &str); 9] = [
    ("camera", "eye"),
    ("camera", "look_at"),
    ("light", "center"),
    ("mesh", "translate"),
    ("quad", "corner"),
    ("box", "min"),
    ("box", "max"),
    ("sphere", "center"),
    ("disk", "center"),
];

/// Moves every absolute position of a parsed scene file by `−origin`, in f64 (the TOML's own
/// precision), so the f32 values read from it keep their digits. Values the first, typed parse
/// accepted are arrays of three numbers; anything else is left for the typed parse to report.
fn rebase_table(table: &mut toml::Table, origin: [f64; 3]) {
    let shift = |v: &mut toml::Value| {
        let Some(a) = v.as_array_mut() else { return };
        if a.len() != 3 {
            return;
        }
        for (x, o) in a.iter_mut().zip(origin) {
            let value = match x {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(i) => *i as f64,
                _ => return,
            };
            *x = toml::Value::Float(value - o);
        }
    };
    for (section, key) in POSITION_KEYS {
        match table.get_mut(section) {
            Some(toml::Value::Table(t)) => {
                if let Some(v) = t.get_mut(key) {
                    shift(v);
                }
            }
            Some(toml::Value::Array(entries)) => {
                for e in entries.iter_mut() {
                    if let Some(v) = e.as_table_mut().and_then(|t| t.get_mut(key)) {
                        shift(v);
                    }
                }
            }
            _ => {}
        }
    }
    // A mesh without `translate` sits at the world origin: it gains the translation −origin.
    if let Some(toml::Value::Array(meshes)) = table.get_mut("mesh") {
        for m in meshes.iter_mut().filter_map(|m| m.as_table_mut()) {
            if !m.contains_key("translate") {
                let t = origin.iter().map(|o| toml::Value::Float(-o)).collect();
                m.insert("translate".into(), toml::Value::Array(t));
            }
        }
    }
}

impl SceneFile {
    fn build(self, path: &Path, origin: [f64; 3]) -> Result<Scene, InputError> {
        let invalid = |key: String, message: String| InputError::InvalidValue {
            path: path.into(),
            key,
            message,
        };
        let keyed = |(key, message): (&str, String)| invalid(key.to_string(), message);
        self.camera.validate().map_err(keyed)?;
        check_finite("light.center", self.light.center).map_err(keyed)?;
        check_size(self.light.radius, true)
            .map_err(|m| invalid("light.radius".into(), format!("{m} (0 is a point light)")))?;

        let base = path.parent().unwrap_or(Path::new("."));
        let mut meshes = Vec::new();
        for (i, entry) in self.mesh.iter().enumerate() {
            let key = |field: &str| format!("mesh[{i}].{field}");
            if !(entry.scale.is_finite() && entry.scale > 0.0) {
                return Err(invalid(
                    key("scale"),
                    format!("is {}, must be finite and > 0", entry.scale),
                ));
            }
            if !entry.rotate_y_deg.is_finite() {
                return Err(invalid(key("rotate_y_deg"), "must be finite".into()));
            }
            check_finite("translate", entry.translate).map_err(|(_, m)| invalid(key("translate"), m))?;
            let mesh_path = base.join(&entry.path);
            let mut mesh = load_obj(&mesh_path)?;
            let rotation = glam::Quat::from_rotation_y(entry.rotate_y_deg.to_radians());
            for p in &mut mesh.positions {
                *p = rotation * (*p * entry.scale) + Vec3::from(entry.translate);
            }
            check_positions(
                &mesh,
                &format!("{} after scale, rotate_y_deg, translate", mesh_path.display()),
            )
            .map_err(|m| invalid(key("scale"), m))?;
            meshes.push(mesh);
        }
        for (i, q) in self.quad.iter().enumerate() {
            check_finite("", q.corner).map_err(|(_, m)| invalid(format!("quad[{i}].corner"), m))?;
            for (field, v) in [("edge_u", q.edge_u), ("edge_v", q.edge_v)] {
                check_direction(v, 2.0 * MAX_COORDINATE)
                    .map_err(|m| invalid(format!("quad[{i}].{field}"), m))?;
            }
            if Vec3::from(q.edge_u).cross(Vec3::from(q.edge_v)).length() == 0.0 {
                return Err(invalid(
                    format!("quad[{i}]"),
                    "has parallel or zero edges: no area".into(),
                ));
            }
            let mesh = shapes::quad("quad", q.corner.into(), q.edge_u.into(), q.edge_v.into());
            check_positions(&mesh, "corner + edge_u + edge_v")
                .map_err(|m| invalid(format!("quad[{i}]"), m))?;
            meshes.push(mesh);
        }
        for (i, b) in self.boxes.iter().enumerate() {
            check_finite("", b.min).map_err(|(_, m)| invalid(format!("box[{i}].min"), m))?;
            check_finite("", b.max).map_err(|(_, m)| invalid(format!("box[{i}].max"), m))?;
            if !(0..3).all(|k| b.min[k] < b.max[k]) {
                return Err(invalid(
                    format!("box[{i}]"),
                    "needs min < max on every axis".into(),
                ));
            }
            meshes.push(shapes::axis_box("box", b.min.into(), b.max.into()));
        }
        for (i, s) in self.sphere.iter().enumerate() {
            check_finite("", s.center).map_err(|(_, m)| invalid(format!("sphere[{i}].center"), m))?;
            check_size(s.radius, false).map_err(|m| invalid(format!("sphere[{i}].radius"), m))?;
            if !(3..=1024).contains(&s.segments) {
                return Err(invalid(
                    format!("sphere[{i}].segments"),
                    format!("is {}, must be in 3..=1024", s.segments),
                ));
            }
            let mesh = shapes::uv_sphere("sphere", s.center.into(), s.radius, s.segments);
            check_positions(&mesh, "center ± radius").map_err(|m| invalid(format!("sphere[{i}]"), m))?;
            meshes.push(mesh);
        }
        for (i, d) in self.disk.iter().enumerate() {
            check_finite("", d.center).map_err(|(_, m)| invalid(format!("disk[{i}].center"), m))?;
            check_direction(d.normal, f32::MAX).map_err(|m| invalid(format!("disk[{i}].normal"), m))?;
            if Vec3::from(d.normal).length() == 0.0 {
                return Err(invalid(format!("disk[{i}].normal"), "is zero".into()));
            }
            check_size(d.radius, false).map_err(|m| invalid(format!("disk[{i}].radius"), m))?;
            if !(3..=65536).contains(&d.segments) {
                return Err(invalid(
                    format!("disk[{i}].segments"),
                    format!("is {}, must be in 3..=65536", d.segments),
                ));
            }
            let mesh = shapes::disk("disk", d.center.into(), d.normal.into(), d.radius, d.segments);
            check_positions(&mesh, "center ± radius").map_err(|m| invalid(format!("disk[{i}]"), m))?;
            meshes.push(mesh);
        }
        let triangles: usize = meshes.iter().map(|m| m.triangles.len()).sum();
        if triangles > MAX_TRIANGLES {
            return Err(invalid(
                "mesh".into(),
                format!("the scene has {triangles} triangles; at most {MAX_TRIANGLES} are accepted"),
            ));
        }
        if meshes.is_empty() {
            return Err(invalid(
                "mesh".into(),
                "is missing: a scene needs at least one [[mesh]], [[quad]], [[box]], [[sphere]] or [[disk]]"
                    .into(),
            ));
        }
        Ok(Scene {
            source: path.into(),
            origin,
            meshes,
            camera: self.camera,
            light: self.light,
        })
    }
}
