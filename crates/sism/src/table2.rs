//! The SISM paper's Table 2 (Johnson et al. 2009): per workload the simulated time of the algorithm's
//! major phases on Larrabee with 24 cores at 1 GHz, their shares and the frame rate, beside the
//! published numbers.
//!
//! **Groups.** The paper reports "data structure construction", "hard shadow kernel" and "soft shadow
//! kernel", as shares of a total that excludes eye-view colour, depth and shading (its shares do not
//! reach 100% because of the light-view rasterization it leaves out). Here, from the simulated phases
//! of a `sism` frame: data structures = `light_samples` and `grid`; hard = `umbra`; soft =
//! `silhouettes` and `penumbra`; other = `resolve` (Eq. 4 and the scatter) and any further phase; the eye pass (eye-view
//! depth: receivers) is reported apart and left out of the shadow total, as the paper leaves it out.
//! So eye + data structures + hard + soft + other = the simulated frame, exactly the phases' sum (tested),
//! and shares and frame rate are of the shadow total.

use crate::machine::MachineReport;
use crate::stats::StatsReport;

/// One of the paper's rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperRow {
    /// Scene name, as in the paper (`palm`).
    pub scene: &'static str,
    /// Triangle count, as printed (`44K`).
    pub triangles: &'static str,
    /// Silhouette edge count, as printed (`--` where the paper has none).
    pub silhouettes: &'static str,
    /// Image size, as printed (`1024x1024`).
    pub image: &'static str,
    /// ms and share (%) of data structures, hard and soft kernels; `None` where the paper has "--".
    pub data_structures: Option<(f64, f64)>,
    /// ms and share (%) of the hard shadow kernel; `None` where the paper has "--".
    pub hard: Option<(f64, f64)>,
    /// ms and share (%) of the soft shadow kernel; `None` where the paper has "--".
    pub soft: Option<(f64, f64)>,
    /// Frame rate, frames per second.
    pub fps: f64,
}

/// The paper's rows for its own algorithm (Table 2, "[Johnson et al. 2009]").
pub const PAPER: [PaperRow; 4] = [
    PaperRow {
        scene: "palm",
        triangles: "44K",
        silhouettes: "--",
        image: "1024x1024",
        data_structures: Some((11.4, 69.0)),
        hard: Some((3.8, 23.0)),
        soft: None,
        fps: 60.0,
    },
    PaperRow {
        scene: "fern",
        triangles: "212K",
        silhouettes: "13K",
        image: "800x600",
        data_structures: Some((6.4, 9.0)),
        hard: Some((3.6, 5.0)),
        soft: Some((55.0, 80.0)),
        fps: 15.0,
    },
    PaperRow {
        scene: "street",
        triangles: "155K",
        silhouettes: "29K",
        image: "1600x1200",
        data_structures: Some((14.2, 38.0)),
        hard: Some((9.8, 26.0)),
        soft: Some((11.6, 31.0)),
        fps: 27.0,
    },
    PaperRow {
        scene: "saloon",
        triangles: "60K",
        silhouettes: "8K",
        image: "1600x1200",
        data_structures: Some((11.9, 40.0)),
        hard: Some((3.6, 12.0)),
        soft: Some((13.6, 45.0)),
        fps: 33.0,
    },
];

/// The paper's row called `scene`.
pub fn paper_row(scene: &str) -> Option<&'static PaperRow> {
    PAPER.iter().find(|r| r.scene == scene)
}

/// Which Table 2 group a `sism` phase belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// The eye pass (`eye_pass`), reported apart from the shadow total.
    Eye,
    /// Data structure construction: `light_samples` and `grid`.
    DataStructures,
    /// The hard shadow kernel: `umbra`.
    Hard,
    /// The soft shadow kernel: `silhouettes` and `penumbra`.
    Soft,
    /// Every other phase (`resolve` and any further one).
    Other,
}

/// The group of phase `phase`.
pub fn group_of(phase: &str) -> Group {
    match phase {
        "eye_pass" => Group::Eye,
        "light_samples" | "grid" => Group::DataStructures,
        "umbra" => Group::Hard,
        "silhouettes" | "penumbra" => Group::Soft,
        _ => Group::Other,
    }
}

/// One measured row.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The workload's name (a paper row's scene, or the file's stem).
    pub workload: String,
    /// Scene triangles.
    pub triangles: u64,
    /// Silhouette edge records (0 for a point light: none are needed).
    pub silhouettes: u64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Simulated ms of each group.
    pub eye_ms: f64,
    /// Simulated ms of the data structures group.
    pub data_structures_ms: f64,
    /// Simulated ms of the hard shadow kernel.
    pub hard_ms: f64,
    /// Simulated ms of the soft shadow kernel.
    pub soft_ms: f64,
    /// Simulated ms of the other phases.
    pub other_ms: f64,
    /// The simulated frame (every phase), ms.
    pub frame_ms: f64,
    /// Cores of the modelled machine.
    pub cores: u32,
    /// Clock of the modelled machine, GHz.
    pub clock_ghz: f64,
    /// A point light (radius 0): hard shadows, no soft shadow kernel.
    pub hard: bool,
}

impl Row {
    /// Groups from a simulated frame and its render's stats.
    pub fn new(workload: &str, report: &MachineReport, stats: &StatsReport, width: u32, height: u32) -> Row {
        let mut row = Row {
            workload: workload.to_string(),
            triangles: stats.get("scene.triangles").unwrap_or(0.0) as u64,
            silhouettes: stats.get("penumbra.silhouettes").unwrap_or(0.0) as u64,
            width,
            height,
            eye_ms: 0.0,
            data_structures_ms: 0.0,
            hard_ms: 0.0,
            soft_ms: 0.0,
            other_ms: 0.0,
            frame_ms: report.frame.ms,
            cores: report.config.cores,
            clock_ghz: report.config.clock_ghz,
            hard: stats.get("scene.light_radius") == Some(0.0),
        };
        for g in &report.groups {
            *match group_of(&g.phase) {
                Group::Eye => &mut row.eye_ms,
                Group::DataStructures => &mut row.data_structures_ms,
                Group::Hard => &mut row.hard_ms,
                Group::Soft => &mut row.soft_ms,
                Group::Other => &mut row.other_ms,
            } += g.ms;
        }
        row
    }

    /// The paper's row this workload stands for: the row of its name (less a `-hard` suffix) with
    /// soft shadows or not as this one.
    pub fn paper(&self) -> Option<&'static PaperRow> {
        paper_row(self.workload.trim_end_matches("-hard")).filter(|p| p.soft.is_none() == self.hard)
    }

    /// The shadow total the paper's shares and frame rate are of: the frame less the eye pass, ms.
    pub fn shadow_ms(&self) -> f64 {
        self.data_structures_ms + self.hard_ms + self.soft_ms + self.other_ms
    }

    /// Share of the shadow total, %.
    pub fn share(&self, ms: f64) -> f64 {
        let t = self.shadow_ms();
        if t > 0.0 {
            100.0 * ms / t
        } else {
            0.0
        }
    }

    /// Frames per second of the shadow total.
    pub fn fps(&self) -> f64 {
        let t = self.shadow_ms();
        if t > 0.0 {
            1000.0 / t
        } else {
            f64::INFINITY
        }
    }
}

/// CSV of measured rows beside the paper's (empty paper columns where there is no such row).
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "workload,triangles,silhouettes,image,cores,clock_ghz,eye_ms,data_structures_ms,data_structures_share,hard_ms,hard_share,\
soft_ms,soft_share,other_ms,shadow_ms,frame_ms,fps,paper_data_structures_ms,paper_hard_ms,paper_soft_ms,paper_fps\n",
    );
    for r in rows {
        let p = r.paper();
        let pc = |f: fn(&PaperRow) -> Option<(f64, f64)>| {
            p.and_then(f).map_or(String::new(), |(ms, _)| format!("{ms}"))
        };
        s += &format!(
            "{},{},{},{}x{},{},{},{:.4},{:.4},{:.2},{:.4},{:.2},{:.4},{:.2},{:.4},{:.4},{:.4},{:.2},{},{},{},{}\n",
            r.workload,
            r.triangles,
            r.silhouettes,
            r.width,
            r.height,
            r.cores,
            r.clock_ghz,
            r.eye_ms,
            r.data_structures_ms,
            r.share(r.data_structures_ms),
            r.hard_ms,
            r.share(r.hard_ms),
            r.soft_ms,
            r.share(r.soft_ms),
            r.other_ms,
            r.shadow_ms(),
            r.frame_ms,
            r.fps(),
            pc(|p| p.data_structures),
            pc(|p| p.hard),
            pc(|p| p.soft),
            p.map_or(String::new(), |p| format!("{}", p.fps)),
        );
    }
    s
}

/// The Markdown table: per workload a row measured here and, under it, the paper's.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "| workload | triangles | silhouettes | image | data structures | hard shadow kernel | soft shadow kernel | other (resolve) | eye pass (not in total) | frame rate |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    let cell = |ms: f64, share: f64| format!("{ms:.1} ms ({share:.0}%)");
    for r in rows {
        let hard_only = r.hard;
        s += &format!(
            "| {} (sism) | {} | {} | {}×{} | {} | {} | {} | {} | {:.1} ms | {:.0} fps |\n",
            r.workload,
            r.triangles,
            if hard_only {
                "--".to_string()
            } else {
                r.silhouettes.to_string()
            },
            r.width,
            r.height,
            cell(r.data_structures_ms, r.share(r.data_structures_ms)),
            cell(r.hard_ms, r.share(r.hard_ms)),
            if hard_only {
                "--".to_string()
            } else {
                cell(r.soft_ms, r.share(r.soft_ms))
            },
            cell(r.other_ms, r.share(r.other_ms)),
            r.eye_ms,
            r.fps()
        );
        if let Some(p) = r.paper() {
            let pc = |v: Option<(f64, f64)>| v.map_or("--".to_string(), |(ms, sh)| cell(ms, sh));
            s += &format!(
                "| {} (paper) | {} | {} | {} | {} | {} | {} | -- | -- | {:.0} fps |\n",
                p.scene,
                p.triangles,
                p.silhouettes,
                p.image.replace('x', "×"),
                pc(p.data_structures),
                pc(p.hard),
                pc(p.soft),
                p.fps
            );
        }
    }
    s
}
