//! A test-only algorithm: `V` = a constant at every receiver facing the light. It exists to show (and
//! test) that an algorithm is one module plus one registry line: render, the registry's help and
//! table, and the stats plumbing all pick it up with no other edit.

use super::params::FloatParam;
use super::{AlgorithmFrame, BenchPlan, Family, FrameInputs, ParamKind, ParamSpec, Params, ReceiverSource};
use crate::exec::FrameLog;
use crate::frame::{VisibilityImage, V_FACING_AWAY, V_MISS};
use crate::stats::StatsReport;

const VALUE: FloatParam = FloatParam::new(ParamSpec {
    key: "value",
    kind: ParamKind::Float { min: 0.0, max: 1.0 },
    default: "0.5",
    description: "the visibility every lit receiver gets",
});

/// The registry entry.
pub static CONSTANT: super::Algorithm = super::Algorithm {
    name: "constant",
    family: Family::Test,
    summary: "V = `value` at every receiver facing the light (test only)",
    params: &[VALUE.spec()],
    receivers: ReceiverSource::Raster,
    kernels: true,
    bench: BenchPlan::Skip,
    run,
};

fn run(inputs: &FrameInputs<'_>, params: &Params, log: &mut FrameLog) -> AlgorithmFrame {
    let value = params.get(&VALUE) as f32;
    let light = inputs.prepared.scene.light.center();
    let r = inputs.receivers;
    let visibility = log.phase("fill", "constant fill", |_| {
        let mut image = VisibilityImage::filled(r.width, r.height, V_MISS);
        for (v, p) in image.values.iter_mut().zip(&r.pixels) {
            if let Some(p) = p {
                *v = if p.normal.dot(light - p.position) > 0.0 {
                    value
                } else {
                    V_FACING_AWAY
                };
            }
        }
        image
    });
    let mut stats = StatsReport::default();
    stats.stat(
        "constant.value",
        value as f64,
        "fraction",
        "the constant visibility",
    );
    AlgorithmFrame { visibility, stats }
}

#[cfg(test)]
mod tests {
    use crate::exec::Exec;
    use crate::render::{render, RenderOptions};
    use crate::scene::Scene;

    #[test]
    fn renders_through_the_registry_and_lists_its_untimed_phase() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/plate.toml");
        let mut scene = Scene::load(&path).unwrap();
        scene.camera.width = 32;
        scene.camera.height = 24;
        let algo = super::super::find("constant").expect("registered");
        let params = algo.params(&[("value".into(), "0.25".into())]).unwrap();
        let r = render(&scene, algo, &params, &RenderOptions::default());
        assert!(r
            .visibility
            .values
            .iter()
            .all(|&v| v.is_nan() || v == 0.25 || v == -1.0));
        assert!(r.visibility.values.contains(&0.25));
        assert_eq!(r.stats.get("constant.value"), Some(0.25));
        assert!(r.stats.get("time.fill").is_some());
        assert!(
            !super::super::markdown_table().contains("| `constant` |"),
            "test-only: not in the README"
        );
        // Counted, the eye pass has task records; the fill has none and is listed as untimed.
        let counted = render(
            &scene,
            algo,
            &params,
            &RenderOptions {
                exec: Exec::Counting,
                ..Default::default()
            },
        );
        let bits =
            |v: &crate::frame::VisibilityImage| v.values.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert!(
            bits(&counted.visibility) == bits(&r.visibility),
            "counted and native differ"
        );
        assert!(counted.records.iter().any(|p| p.group() == "eye_pass"));
        assert!(counted.stats.get("machine.untimed.fill").is_some());
    }
}
