"""The rdr Python package against the rdr command line (run by .ci/run after the
cargo tests, which build target/release/rdr; RDR_BIN names another binary)."""

import gc
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import rdr

ROOT = Path(__file__).resolve().parents[2]
SHOWCASE = ROOT / "scenes" / "showcase.json"
ROUGHPLASTIC = ROOT / "tests" / "refs" / "materials" / "roughplastic.xml"
# a small showcase, so that every render here takes a fraction of a second
SMALL = {"film": {"resolution": [48, 32]}}


def rdr_bin():
    path = Path(os.environ.get("RDR_BIN", ROOT / "target" / "release" / "rdr"))
    if not path.is_file():
        pytest.fail(f"{path}: no rdr binary (cargo build --release first, or set RDR_BIN)")
    return path


def cli(*args):
    """Runs rdr; (exit status, standard error)."""
    p = subprocess.run([str(rdr_bin()), *map(str, args)], capture_output=True, text=True, timeout=300)
    return p.returncode, p.stderr


def cli_render(tmp_path, scene, *args):
    """`rdr render SCENE ARGS -o out.exr`, read back."""
    out = tmp_path / "cli.exr"
    status, err = cli("render", scene, *args, "-q", "-o", out)
    assert status == 0, err
    return rdr.read(out)


def small_showcase(**kw):
    return rdr.load_file(SHOWCASE, overrides=[SMALL], **kw)


def test_render_equals_the_cli_bit_for_bit(tmp_path):
    image = rdr.render(small_showcase(), spp=3, seed=7)
    ref = cli_render(tmp_path, SHOWCASE, "--override", json.dumps(SMALL), "--spp", 3, "--seed", 7)
    assert image.shape == ref.shape == (32, 48, 3)
    assert np.array_equal(image.view(np.ndarray), ref.view(np.ndarray))
    # another seed is another image, so equality above is not a blank match
    assert not np.array_equal(rdr.render(small_showcase(), spp=3, seed=8), image)


def test_thread_count_does_not_change_the_image():
    scene = small_showcase()
    one = rdr.render(scene, spp=2, threads=1)
    two = rdr.render(scene, spp=2, threads=2)
    assert np.array_equal(one, two)


def test_xml_parameters_and_overrides_as_the_cli_takes_them(tmp_path):
    image = rdr.render(rdr.load_file(ROUGHPLASTIC, spp=3), seed=1)
    assert np.array_equal(image, cli_render(tmp_path, ROUGHPLASTIC, "-D", "spp=3", "--seed", 1))
    depth = {"integrator": {"max_depth": 1}}
    shallow = rdr.render(rdr.load_file(SHOWCASE, overrides=[SMALL, depth]), spp=2)
    assert np.array_equal(shallow, cli_render(tmp_path, SHOWCASE, "--override", json.dumps(SMALL), "--override", json.dumps(depth), "--spp", 2))
    assert not np.array_equal(shallow, rdr.render(small_showcase(), spp=2))
    # a scene's own spp when none is given
    assert rdr.load_file(ROUGHPLASTIC, spp=5).spp == 5


def test_json_dict_renders_as_its_file(monkeypatch):
    d = json.loads(SHOWCASE.read_text())
    d["film"]["resolution"] = [48, 32]
    monkeypatch.chdir(SHOWCASE.parent)
    assert np.array_equal(rdr.render(rdr.load_dict(d), spp=2), rdr.render(small_showcase(), spp=2))


def mitsuba_dict(matrix):
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 8},
        "sensor": {
            "type": "perspective",
            "fov": 30.0,
            "fov_axis": "y",
            "to_world": matrix,
            "film": {"type": "hdrfilm", "width": 24, "height": 16, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": 4},
        },
        "blue": {"type": "roughplastic", "alpha": 0.15, "diffuse_reflectance": {"type": "rgb", "value": [0.1, 0.3, 0.8]}},
        "lamp": {
            "type": "sphere",
            "center": [2.0, 3.0, -2.0],
            "radius": 0.5,
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [20.0, 20.0, 20.0]}},
        },
        "ball": {"type": "sphere", "radius": 1.0, "bsdf": {"type": "ref", "id": "blue"}},
        "ground": {"type": "sphere", "center": [0, -101, 0], "radius": 100.0, "bsdf": {"type": "diffuse"}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.3, 0.3, 0.3]}},
    }


MITSUBA_XML = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="8"/></integrator>
  <sensor type="perspective"><float name="fov" value="30.0"/><string name="fov_axis" value="y"/>
    <transform name="to_world"><matrix value="{m}"/></transform>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/><rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler></sensor>
  <bsdf type="roughplastic" id="blue"><float name="alpha" value="0.15"/><rgb name="diffuse_reflectance" value="0.1, 0.3, 0.8"/></bsdf>
  <shape type="sphere"><point name="center" value="2, 3, -2"/><float name="radius" value="0.5"/>
    <emitter type="area"><rgb name="radiance" value="20, 20, 20"/></emitter></shape>
  <shape type="sphere"><float name="radius" value="1"/><ref id="blue"/></shape>
  <shape type="sphere"><point name="center" value="0, -101, 0"/><float name="radius" value="100"/><bsdf type="diffuse"/></shape>
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.3, 0.3"/></emitter>
</scene>
"""


def test_mitsuba_dict_renders_as_its_xml(tmp_path):
    # a camera at (0, 0.6, -4.5) looking at the origin: Mitsuba's look_at, row-major
    m = np.array([[1, 0, 0, 0], [0, 0.99119, -0.13216, 0.6], [0, 0.13216, 0.99119, -4.5], [0, 0, 0, 1]])
    xml = tmp_path / "twin.xml"
    xml.write_text(MITSUBA_XML.format(m=" ".join(repr(float(x)) for x in m.ravel())))
    image = rdr.render(rdr.load_dict(mitsuba_dict(m)), seed=2)
    assert image.shape == (16, 24, 3)
    assert np.array_equal(image, cli_render(tmp_path, xml, "--seed", 2))
    # the dict's order and values matter: another roughness is another image
    d = mitsuba_dict(m.tolist())
    d["blue"]["alpha"] = 0.4
    assert not np.array_equal(rdr.render(rdr.load_dict(d), seed=2), image)


def cli_error(*args):
    status, err = cli(*args)
    assert status == 1
    line = err.strip().splitlines()[-1]
    assert line.startswith("error: ")
    return line[len("error: "):]


def test_errors_carry_the_cli_message(tmp_path):
    missing = tmp_path / "missing.json"
    with pytest.raises(rdr.Error) as e:
        rdr.load_file(missing)
    assert str(e.value) == cli_error("render", missing, "-o", tmp_path / "x.exr")
    bad = {"materials": {"blue": {"type": "diffuse", "texture_name": "nowhere"}}}
    with pytest.raises(rdr.Error) as e:
        rdr.load_file(SHOWCASE, overrides=[bad])
    assert str(e.value) == cli_error("render", SHOWCASE, "--override", json.dumps(bad), "-o", tmp_path / "x.exr")
    assert "materials.blue" in str(e.value)
    assert isinstance(e.value, RuntimeError)


def test_errors_of_dicts_and_options_name_the_key():
    with pytest.raises(rdr.Error, match=r"^<dict>: ball\.bsdf\.type: unknown plugin type \"difuse\"$"):
        rdr.load_dict({"type": "scene", "ball": {"type": "sphere", "bsdf": {"type": "difuse"}}})
    with pytest.raises(rdr.Error, match=r"^<dict>: camera: "):
        rdr.load_dict({"integrator": {"type": "path"}, "film": {"resolution": [8, 8]}, "camera": 3})
    scene = small_showcase()
    with pytest.raises(rdr.Error, match="^spp must be at least 1$"):
        rdr.render(scene, spp=0)
    with pytest.raises(rdr.Error, match="^threads must be at least 1$"):
        rdr.render(scene, threads=0)
    with pytest.raises(rdr.Error, match="^time_limit must be a positive number of seconds$"):
        rdr.render(scene, time_limit=-1)
    with pytest.raises(rdr.Error, match="^aovs: unknown AOV 'colour'"):
        rdr.render(scene, aovs=["colour"])
    with pytest.raises(rdr.Error, match="^integrator: integrator.type: unknown integrator 'paht'"):
        rdr.render(scene, integrator="paht")


def test_array_shape_dtype_and_ownership():
    scene = small_showcase()
    image = rdr.render(scene, spp=1)
    assert isinstance(image, np.ndarray) and isinstance(image, rdr.Image)
    assert image.shape == (32, 48, 3) and image.dtype == np.float32
    assert image.flags.c_contiguous and image.flags.writeable
    # the pixels are the render's own buffer, handed over: numpy did not copy them
    base = image.base
    while isinstance(base, np.ndarray):
        assert not base.flags.owndata
        base = base.base
    assert type(base).__name__ == "PySliceContainer"
    first = image.copy()
    del scene
    gc.collect()
    assert np.array_equal(image, first) and np.isfinite(image).all() and image.mean() > 0
    assert image._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"


def test_feature_buffers_join_the_colour():
    scene = small_showcase()
    image = rdr.render(scene, spp=2, aovs=("albedo", "depth"))
    assert image.shape == (32, 48, 7)
    assert image.channels == ("R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "depth.Z")
    assert np.array_equal(image[..., :3], rdr.render(scene, spp=2))
    assert image[..., 6].max() > 1.0


def test_another_integrator_per_render(tmp_path):
    scene = small_showcase()
    normals = rdr.render(scene, spp=1, integrator="normals")
    ref = cli_render(tmp_path, SHOWCASE, "--override", json.dumps({**SMALL, "integrator": {"type": "normals"}}), "--spp", 1)
    assert np.array_equal(normals, ref)
    # the scene keeps its own integrator
    assert scene.integrator == "path"


def test_traverse_update_equals_loading_the_edited_scene(monkeypatch):
    scene = small_showcase()
    params = rdr.traverse(scene)
    assert params["camera.fov"] == 30.0 and params["film.resolution"] == [48, 32]
    params["textures.blue.color"] = [0.8, 0.1, 0.1]
    params["materials.gold.alpha_x"] = 0.4
    params["objects[1].light.radiance"] = np.array([5.0, 30.0, 5.0])
    params["camera.fov"] = 36.0
    params["film.resolution"] = [40, 24]
    assert sorted(params.update()) == sorted(
        ["textures.blue.color", "materials.gold.alpha_x", "objects[1].light.radiance", "camera.fov", "film.resolution"]
    )
    edited = rdr.render(scene, spp=2)
    d = json.loads(SHOWCASE.read_text())
    d["textures"]["blue"]["color"] = [0.8, 0.1, 0.1]
    d["materials"]["gold"]["alpha_x"] = 0.4
    d["objects"][1]["light"]["radiance"] = [5.0, 30.0, 5.0]
    d["camera"]["fov"] = 36.0
    d["film"]["resolution"] = [40, 24]
    monkeypatch.chdir(SHOWCASE.parent)
    assert edited.shape == (24, 40, 3)
    assert np.array_equal(edited, rdr.render(rdr.load_dict(d), spp=2))


def test_traverse_refuses_by_key_and_applies_all_or_nothing():
    scene = small_showcase()
    params = rdr.traverse(scene)
    with pytest.raises(KeyError, match=r"objects\[0\]\.path: not a parameter that can change between renders"):
        params["objects[0].path"] = "x.obj"
    before = rdr.render(scene, spp=1)
    params["textures.blue.color"] = [0.0, 1.0, 0.0]
    params["camera.fov"] = 500.0
    with pytest.raises(rdr.Error, match=r"^camera\.fov: expected a number of degrees between 0 and 180$"):
        params.update()
    assert np.array_equal(rdr.render(scene, spp=1), before)
    assert rdr.traverse(scene)["textures.blue.color"] != [0.0, 1.0, 0.0]


def test_progress_reports_every_sample():
    calls = []
    image = rdr.render(small_showcase(), spp=2, progress=lambda done, total: calls.append((done, total)))
    assert calls and calls[-1] == (48 * 32 * 2, 48 * 32 * 2)
    assert all(a[0] <= b[0] for a, b in zip(calls, calls[1:]))
    assert image.shape == (32, 48, 3)


def test_write_and_read_as_the_cli_writes(tmp_path):
    image = rdr.render(small_showcase(), spp=2)
    rdr.write(tmp_path / "a.exr", image)
    assert np.array_equal(rdr.read(tmp_path / "a.exr"), image)
    rdr.write(tmp_path / "a.png", image)
    status, err = cli("render", SHOWCASE, "--override", json.dumps(SMALL), "--spp", 2, "-q", "-o", tmp_path / "cli.png")
    assert status == 0, err
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    assert image._repr_png_() == (tmp_path / "cli.png").read_bytes()
    assert rdr.compare(image, image) == 0.0
    noisy = rdr.render(small_showcase(), spp=1, seed=5)
    rdr.write(tmp_path / "b.exr", noisy)
    status = subprocess.run([str(rdr_bin()), "compare", tmp_path / "b.exr", tmp_path / "a.exr"], capture_output=True, text=True)
    line = [x for x in status.stdout.splitlines() if x.startswith("relMSE")][0]
    assert float(line.split()[1]) == pytest.approx(rdr.compare(noisy, image), rel=1e-3)


CTRL_C_CHILD = """
import json, sys, rdr
scene = rdr.load_file(sys.argv[1], overrides=[json.loads(sys.argv[2])])
print("start", flush=True)
try:
    # no progress callback: only render's own polling can see the signal
    rdr.render(scene, spp=1000000)
    print("finished")
except rdr.RenderInterrupted as e:
    assert isinstance(e, KeyboardInterrupt)
    import numpy as np
    print("interrupted", e.spp, e.image.shape, bool(np.isfinite(e.image).all()), float(e.image.mean()) > 0, flush=True)
"""


def test_ctrl_c_stops_between_passes_and_keeps_the_finished_ones(tmp_path):
    child = tmp_path / "child.py"
    child.write_text(textwrap.dedent(CTRL_C_CHILD))
    args = [sys.executable, str(child), str(SHOWCASE), json.dumps(SMALL)]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "start"
        time.sleep(1.5)  # a pass of the 48x32 film takes milliseconds
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
    finally:
        p.kill()
    assert p.returncode == 0, err
    words = out.split()
    assert words[0] == "interrupted", out
    assert 1 <= int(words[1]) < 1000000
    assert words[2:] == ["(32,", "48,", "3)", "True", "True"]


def test_example_notebook_runs(monkeypatch):
    """The example notebook's code, on a small film (its own is for people, not CI)."""
    notebook = ROOT / "python" / "examples" / "quickstart.ipynb"
    cells = json.loads(notebook.read_text())["cells"]
    assert all(c.get("outputs", []) == [] for c in cells), "commit the notebook without outputs"
    load = rdr.load_file
    monkeypatch.setattr(rdr, "load_file", lambda path, **kw: load(path, overrides=[SMALL], **kw))
    monkeypatch.chdir(notebook.parent)
    namespace = {}
    for c in cells:
        if c["cell_type"] == "code":
            exec(compile("".join(c["source"]), str(notebook), "exec"), namespace)
    errors = namespace["errors"]
    assert len(errors) == 7 and errors[-1] < errors[0] / 8


def test_traverse_leaves_out_colours_a_light_copied():
    # a constant <emitter> is a sky built from its texture's colour: editing the texture
    # alone would not change the light, so it is not offered
    scene = rdr.load_file(ROUGHPLASTIC, spp=1)
    params = rdr.traverse(scene)
    assert "materials.bsdf_2.alpha" in params
    assert not any(k.startswith("textures.") for k in params)
    with pytest.raises(KeyError, match="not a parameter that can change"):
        params["textures.environment.color"] = [1.0, 0.0, 0.0]
