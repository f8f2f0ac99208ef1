"""The Python package against the command line it shares a library with: the same images bit for
bit, the same counters, the same comparison figures; errors as Python exceptions with the
library's message; ꟻLIP against NVIDIA's own tool; EXR read by a second reader; a small study."""

import math
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import sism
from conftest import read_pfm, read_stats

W, H = 64, 48


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def test_algorithms_lists_every_method_with_parameters():
    algos = {a["name"]: a for a in sism.algorithms()}
    for name in ["reference", "sism", "sism-sampled", "pcss", "rsmss", "ssmm", "light-samples"]:
        assert name in algos, name
    assert algos["sism-sampled"]["machine"] is True
    assert algos["reference"]["machine"] is False
    spp = {p["key"]: p for p in algos["reference"]["params"]}["spp"]
    assert spp["default"].isdigit() and ".." in spp["range"] and spp["description"]
    assert all(a["family"] and a["summary"] for a in algos.values())


def test_load_scene_sizes_and_errors(plate, tmp_path):
    s = sism.load_scene(plate, width=W, height=H)
    assert (s.width, s.height) == (W, H)
    assert s.triangles == 4 and s.light_radius == pytest.approx(0.5)
    assert "plate.toml" in repr(s)
    with pytest.raises(OSError, match="no-such-scene.toml"):
        sism.load_scene(tmp_path / "no-such-scene.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[camera]\neye = [0, 0\n")
    with pytest.raises(ValueError, match="bad.toml"):
        sism.load_scene(bad)
    with pytest.raises(ValueError, match="width"):
        sism.load_scene(plate, width=0)


def test_render_matches_the_cli_bit_for_bit_with_the_same_counters(plate, cli, tmp_path):
    scene = sism.load_scene(plate, width=W, height=H)
    for algo, params, args in [
        ("pcss", None, []),
        ("reference", {"spp": 16, "seed": 3}, ["--param", "spp=16", "--param", "seed=3"]),
        ("sism-sampled", None, []),
    ]:
        r = sism.render(scene, algo, params=params)
        v = r.visibility
        assert v.dtype == np.float32 and v.shape == (H, W)
        ok = np.isnan(v) | (v == -1) | ((v >= 0) & (v <= 1))
        assert ok.all(), f"{algo}: values outside the contract"
        out = tmp_path / algo
        cli("render", plate, "--algo", algo, "--width", W, "--height", H, "--out", out, "--quiet", *args)
        assert np.array_equal(bits(v), bits(read_pfm(out / "visibility.pfm"))), algo
        # The same image through the package's own reader, from either format.
        assert np.array_equal(bits(sism.read_visibility(out / "visibility.exr")), bits(v))
        # Counters: every stats.json entry but host times is the same value and unit.
        cli_stats = read_stats(out / "stats.json")["stats"]
        for name, entry in cli_stats.items():
            # Host times and rates differ from run to run; every count must not.
            if entry["unit"] in ("ms", "s") or entry["unit"].endswith("/s"):
                continue
            assert name in r.stats, f"{algo}: {name} missing"
            value, unit = r.stats[name]
            assert unit == entry["unit"], name
            assert value == entry["value"], f"{algo}: {name} {value} != {entry['value']}"
        assert r.facts["algorithm"] == algo


def test_render_on_a_machine_gives_phases_and_the_same_image(plate):
    scene = sism.load_scene(plate, width=W, height=H)
    native = sism.render(scene, "sism")
    timed = sism.render(scene, "sism", machine="larrabee-16")
    assert np.array_equal(bits(native.visibility), bits(timed.visibility))
    m = timed.machine
    assert m["cores"] == 16 and m["clock_ghz"] > 0
    frame = m["frame"]
    assert frame["ms"] > 0 and frame["cycles"] > 0
    assert sum(frame["stack"].values()) == frame["cycles"]
    assert timed.phase_ms and all(ms >= 0 for ms in timed.phase_ms.values())
    assert math.isclose(sum(p["cycles"] for p in m["phases"]), frame["cycles"], rel_tol=1e-9)
    assert native.machine is None and native.phase_ms == {}


def test_errors_are_python_exceptions_with_the_librarys_message(plate):
    scene = sism.load_scene(plate, width=W, height=H)
    with pytest.raises(ValueError, match="unknown algorithm `nope`.*sism-sampled"):
        sism.render(scene, "nope")
    with pytest.raises(ValueError, match="spp"):
        sism.render(scene, "reference", params={"spp": -4})
    with pytest.raises(ValueError, match="unknown|no parameter|not a parameter"):
        sism.render(scene, "pcss", params={"no_such_key": 1})
    with pytest.raises(ValueError, match="simd kernels"):
        sism.render(scene, "reference", machine="larrabee-16")
    with pytest.raises((ValueError, OSError), match="no-such-machine"):
        sism.render(scene, "sism", machine="no-such-machine")
    with pytest.raises(ValueError, match="differ in size"):
        sism.compare(np.zeros((4, 4), np.float32), np.zeros((4, 5), np.float32))
    with pytest.raises(ValueError, match="2-D"):
        sism.compare(np.zeros(4, np.float32), np.zeros(4, np.float32))
    with pytest.raises(ValueError, match="holds 2"):
        sism.compare(np.zeros((2, 2), np.float32), np.full((2, 2), 2.0, np.float32))


def test_compare_matches_the_cli_and_flip_matches_nvidias_tool(plate, cli, tmp_path):
    common = ["--width", W * 2, "--height", H * 2, "--quiet"]
    cli("render", plate, "--algo", "reference", "--spp", 64, "--out", tmp_path / "ref", *common)
    cli("render", plate, "--algo", "pcss", "--out", tmp_path / "pcss", *common)
    ref, test = tmp_path / "ref" / "visibility.pfm", tmp_path / "pcss" / "visibility.exr"
    import json

    expected = json.loads(cli("compare", ref, test, "--json"))
    got = sism.compare(ref, test)
    assert set(got) == set(expected)
    for key, value in expected.items():
        assert got[key] == pytest.approx(value, rel=1e-12, abs=0), key
    assert 0 < got["flip"] < 1
    # Shading from the scene gives the same ꟻLIP as the shaded.png files beside the images.
    scene = sism.load_scene(plate, width=W * 2, height=H * 2)
    arrays = sism.compare(read_pfm(ref), sism.read_visibility(test), scene=scene)
    assert arrays["flip"] == pytest.approx(got["flip"], abs=1e-9)
    assert arrays["mae"] == got["mae"]
    # Bare arrays: no shading, no ꟻLIP.
    assert sism.compare(read_pfm(ref), read_pfm(ref))["flip"] is None
    # NVIDIA's tool on the same two shaded images. nv-flip binds ꟻLIP 1.2's C++; flip-evaluator is
    # 1.7, whose means differ by about 1e-5 (see crates/sism/src/perceptual.rs).
    flip = pytest.importorskip("flip_evaluator")
    _, mean, _ = flip.evaluate(
        str(tmp_path / "ref" / "shaded.png"), str(tmp_path / "pcss" / "shaded.png"), "LDR"
    )
    assert got["flip"] == pytest.approx(mean, abs=1e-4)


def test_exr_files_open_in_a_second_reader(plate, cli, tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    cli("render", plate, "--algo", "pcss", "--width", W, "--height", H, "--out", tmp_path, "--quiet")
    with OpenEXR.File(str(tmp_path / "visibility.exr")) as f:
        channels = f.channels()
        assert list(channels) == ["V"]
        v = channels["V"].pixels
    assert v.dtype == np.float32 and v.shape == (H, W)
    assert np.array_equal(bits(v), bits(read_pfm(tmp_path / "visibility.pfm")))
    assert np.isnan(v).any(), "misses stay NaN"
    with OpenEXR.File(str(tmp_path / "shaded.exr")) as f:
        rgb = next(iter(f.channels().values())).pixels
    assert rgb.dtype == np.float16 and rgb.shape == (H, W, 3)
    assert 0 <= float(np.nanmin(rgb)) and float(np.nanmax(rgb)) <= 4.0


def test_study_rows_make_a_dataframe_and_match_the_cli(plate, cli, tmp_path):
    scene = sism.load_scene(plate, width=W, height=H)
    rows = sism.study(scene, machine="larrabee-16", algo="sism", cores=[8, 16], threads=[4])
    frames = [r for r in rows if r["level"] == "frame"]
    assert [r["cores"] for r in frames] == [8, 16]
    assert frames[0]["frame_speedup"] == 1.0
    assert frames[1]["frame_speedup"] == pytest.approx(frames[0]["cycles"] / frames[1]["cycles"])
    assert {r["level"] for r in rows} == {"frame", "phase", "step"}
    pd = pytest.importorskip("pandas")
    df = pd.DataFrame(rows)
    assert len(df) == len(rows) and {"cores", "ms", "issue", "memory"} <= set(df.columns)
    # The CLI's study of the same frame: the same frame cycles per point, to the few cycles that
    # data on the calling thread's stack can move (its lines straddle differently in another
    # process: ARCHITECTURE.md, "The machine model", on stack lines).
    cli("study", plate, "--machine", "larrabee-16", "--algo", "sism", "--cores", "8,16",
        "--threads", "4", "--width", W, "--height", H, "--out", tmp_path / "st", "--quiet")
    lines = (tmp_path / "st" / "study.csv").read_text().splitlines()
    header = lines[0].split(",")
    cli_frames = [dict(zip(header, l.split(","))) for l in lines[1:]]
    cli_frames = [r for r in cli_frames if r["phase"] == "frame"]
    assert [int(r["cores"]) for r in cli_frames] == [8, 16]
    for ours, theirs in zip(frames, cli_frames):
        assert ours["cycles"] == pytest.approx(int(theirs["cycles"]), rel=1e-3)
    with pytest.raises(ValueError):
        sism.study(scene, machine="larrabee-16", cores=[0])


def test_work_releases_the_gil(plate):
    scene = sism.load_scene(plate, width=320, height=240)
    done = threading.Event()

    def work():
        sism.render(scene, "reference", params={"spp": 256})
        done.set()

    t = threading.Thread(target=work)
    t.start()
    ticks = 0
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    # With the GIL held through the render, this thread could not run until it ended.
    assert ticks > 5, ticks


def test_simd_backend_is_named():
    assert sism.simd_backend() in ("avx512", "portable")
