"""The on-disk caches hold verified data only (issue 9).

Every damaged, edited, swapped or planted entry is reported in one stderr line and re-derived:
the numbers then equal those of a fresh derivation (the oracle: ``compile_scene(...,
use_cache=False)`` with the shape cache in another, empty folder). Nothing in the cache is ever
unpickled; concurrent writers leave one entry and no temporary folders.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import pathlib
import pickle
import time
from pathlib import Path

import numpy as np
import pytest
import sympy

from symgen import cache, exprdata
from symgen.model import shape_cache as S
from symgen.model.shapes import SHAPES_VERSION
from symgen.cli import main
from symgen.backends.casadi import store as casadi_io
from symgen.backends.casadi.pipeline import compile_scene
from symgen.ir.parameters import parameter_values
from symgen.scene import load_scene
from symgen.numerics import compiled

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "slider_crank.toml"


def _numbers(compiled, scene) -> dict[str, np.ndarray]:
    """Every Function of a model at fixed inputs, with this scene's parameter values."""
    info = compiled.info
    nq, nlam = info.n, info.m
    rng = np.random.default_rng(7)
    args = [
        0.3,
        rng.normal(size=nq) * 0.1,
        rng.normal(size=nq),
        rng.normal(size=nq),
        rng.normal(size=nlam),
        parameter_values(scene, info.params),
    ]
    return {name: np.array(f(*args)).ravel() for name, f in compiled.funcs.items()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The oracle: a fresh derivation in a cache folder of its own."""
    with pytest.MonkeyPatch.context() as mpatch:
        mpatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path_factory.mktemp("reference-cache")))
        S.clear_memory_cache()
        scene = load_scene(SCENE)
        compiled = compile_scene(scene, use_cache=False)
        S.clear_memory_cache()
        return _numbers(compiled, scene)


@pytest.fixture
def root(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    S.clear_memory_cache()
    yield tmp_path / "cache"
    S.clear_memory_cache()


def _entry(root: Path) -> Path:
    (entry,) = [p for p in (root / "models").iterdir() if not p.name.startswith(".")]
    return entry


def _fill(root: Path):
    """Derive into the empty cache; the entry's folder."""
    compiled = compile_scene(load_scene(SCENE))
    assert not compiled.cached
    return _entry(root)


def _recompile(capsys, expect: str | None):
    """Compile from the (tampered) cache; check the stderr line; the model."""
    S.clear_memory_cache()
    compiled = compile_scene(load_scene(SCENE))
    err = capsys.readouterr().err
    if expect is None:
        assert err == ""
    else:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("symgen: warning: cache entry ") and expect in lines[0], err
        assert lines[0].endswith("re-deriving it")
    return compiled


def _assert_equal(compiled, reference):
    got = _numbers(compiled, load_scene(SCENE))
    assert set(got) == set(reference)
    for name in reference:
        np.testing.assert_allclose(got[name], reference[name], rtol=1e-12, atol=1e-12, err_msg=name)


def _flip_bit(path: Path, at: float = 0.5, bit: int = 0) -> None:
    data = bytearray(path.read_bytes())
    i = int(len(data) * at)
    data[i] ^= 1 << bit
    path.write_bytes(bytes(data))


def _no_temp(root: Path) -> None:
    left = [
        p
        for sub in ("models", "shapes")
        if (root / sub).is_dir()
        for p in (root / sub).iterdir()
        if p.name.startswith(".tmp-") or p.name.endswith(".tmp")
    ]
    assert left == []


# ----------------------------------------------------------------------------- pickle
class _Payload:
    """Unpickling this creates the file ``marker`` (what a planted pickle could do)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (pathlib.Path.touch, (pathlib.Path(self.marker),))


def test_planted_pickles_are_never_loaded(root, capsys, reference, tmp_path):
    marker = tmp_path / "pwned"
    evil = pickle.dumps(_Payload(marker))
    pickle.loads(evil)  # the payload works...
    assert marker.exists()
    marker.unlink()

    shapes = root / "shapes"
    shapes.mkdir(parents=True)
    name = S._cache_name(("axial", "stress-free", "any", 1, False), ("transverse", "modes", "pinned-pinned", 1, False))
    old = name.replace(f"v{SHAPES_VERSION}__", "v2__")
    # where older symgen read its pickles, and the current entry names: a pickle, and a pickle
    # behind a header whose plain sha256 matches it (the keyed hash cannot be made without the key)
    (shapes / f"{old}.pkl").write_bytes(evil)
    (shapes / f"{name}.pkl").write_bytes(evil)
    (shapes / f"{name}.json").write_bytes(
        b"symgen-cache shapes hmac-sha256=%s\n" % cache.sha256_hex(evil).encode() + evil
    )
    key = _fill_key()
    entry = root / "models" / key
    entry.mkdir(parents=True)
    for fname in casadi_io.FUNCTION_NAMES:
        (entry / f"{fname}.casadi").write_bytes(evil)
    (entry / "model.json").write_bytes(evil)

    compiled = compile_scene(load_scene(SCENE))
    err = capsys.readouterr().err
    assert not marker.exists()
    assert not compiled.cached
    _assert_equal(compiled, reference)
    assert f"{name}.json does not match the keyed hash" in err, err
    assert f"models/{key} has no manifest.json" in err
    assert len(err.strip().splitlines()) == 2  # one line per entry
    # the planted entries were overwritten by verified ones; old pickles stay ignored
    assert cache.unpack("shapes", (shapes / f"{name}.json").read_bytes()).startswith(b"{")
    assert _recompile(capsys, None).cached
    assert not marker.exists()


def _fill_key() -> str:
    from symgen.model.structure import structure_key, structure_of

    return structure_key(structure_of(load_scene(SCENE)))


# ----------------------------------------------------------------------------- flipped bits
@pytest.mark.parametrize("fname", ["res.casadi", "phi.casadi", "model.json", "manifest.json"])
def test_flipped_bit_in_model_entry_is_rederived(root, capsys, reference, fname):
    entry = _fill(root)
    _flip_bit(entry / fname, at=0.5, bit=1)
    expect = f"{fname} does not match the keyed hash" if fname != "manifest.json" else f"models/{entry.name} "
    compiled = _recompile(capsys, expect)
    assert not compiled.cached
    _assert_equal(compiled, reference)
    again = _recompile(capsys, None)  # rewritten: verifies now
    assert again.cached
    _assert_equal(again, reference)
    _no_temp(root)


def test_flipped_bit_in_shape_cache_is_recomputed(root, capsys, reference):
    _fill(root)
    (entry,) = [p for p in (root / "shapes").iterdir() if "n1" in p.name]
    good = entry.read_bytes()
    for at, bit in ((0.3, 0), (0.0, 3), (0.99, 2)):  # in the payload, in the header, near the end
        entry.write_bytes(good)
        _flip_bit(entry, at=at, bit=bit)
        S.clear_memory_cache()
        compiled = compile_scene(load_scene(SCENE), use_cache=False)
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and entry.name in err[0], err
        _assert_equal(compiled, reference)
        assert entry.read_bytes() == good  # rewritten, byte for byte
    # a digit changed so that the JSON stays valid (the value 7*pi**2/15 of C3 as a float, say)
    payload = good.split(b"\n", 1)[1]
    doc = json.loads(payload)
    doc["floats"]["C3"][0] *= 1.5
    entry.write_bytes(good.split(b"\n", 1)[0] + b"\n" + json.dumps(doc, separators=(",", ":")).encode())
    S.clear_memory_cache()
    compiled = compile_scene(load_scene(SCENE), use_cache=False)
    assert "keyed hash" in capsys.readouterr().err
    _assert_equal(compiled, reference)


# ----------------------------------------------------------------------------- edited metadata
def test_edited_model_json_is_rederived(root, capsys, reference):
    entry = _fill(root)
    meta = json.loads((entry / "model.json").read_text())
    meta["params"] = meta["params"][::-1]  # valid JSON, same sizes: silently wrong numbers if used
    (entry / "model.json").write_text(json.dumps(meta, indent=1, sort_keys=True))
    compiled = _recompile(capsys, "model.json does not match the keyed hash")
    assert not compiled.cached
    assert list(compiled.info.params) == sorted(compiled.info.params, key=str) != meta["params"]
    _assert_equal(compiled, reference)


def _resign_model_json(entry: Path, edit) -> None:
    """Edit model.json's data with ``edit`` and re-sign it in the manifest (hashes match: only
    the reading of model.json itself can catch the edit)."""
    data = json.loads((entry / "model.json").read_text())
    edit(data)
    blob = json.dumps(data).encode()
    (entry / "model.json").write_bytes(blob)
    manifest = json.loads((entry / "manifest.json").read_text())
    manifest["files"]["model.json"] = cache.seal(f"models/{entry.name}/model.json", blob)  # a keyed writer
    (entry / "manifest.json").write_text(json.dumps(manifest))


@pytest.mark.parametrize(
    "edit, expect",
    [
        (lambda d: d["coords"][0].pop("kind"), "model.json: coords[0] has no 'kind'"),
        (
            lambda d: d["coords"][1].update(kind="h"),
            "model.json: coords[1].kind 'h' is not one of theta, s, f, g, beta",
        ),
        (lambda d: d["coords"][1].update(name="f_other_1"), "model.json: coords[1] is named 'f_other_1', not after"),
        (lambda d: d["lam_rows"][0].update(kind="weld"), "model.json: lam_rows[0].kind 'weld' is not one of"),
        (lambda d: d.update(driver_row=0), "model.json: 'driver_row' is not the index of the driver's row"),
        (lambda d: d.pop("modes"), "model.json: the model description has no 'modes'"),
        (lambda d: d["modes"]["rod"].update(axial="1"), "model.json: modes.rod.axial is not a count"),
        (lambda d: d.update(timings={"derive_s": "fast"}), "model.json: 'timings' is not an object of numbers"),
        (lambda d: d.update(scene_name="old"), "model.json: the model description has an unknown field 'scene_name'"),
        (lambda d: d.update(params=d["params"][:1] * 2), "model.json: 'params' are not distinct names"),
    ],
)
def test_malformed_model_json_is_rederived_not_a_key_error(root, capsys, reference, edit, expect):
    """A model.json edited and re-signed by a keyed writer (so its hash matches) is read field by field
    (ir.info.ModelInfo.from_json): a missing or wrong field is an invalid entry, re-derived,
    never a KeyError or a model run with wrong meaning."""
    entry = _fill(root)
    _resign_model_json(entry, edit)
    compiled = _recompile(capsys, expect)
    assert not compiled.cached
    _assert_equal(compiled, reference)


def test_entry_of_another_structure_is_rederived(root, capsys, reference):
    """A whole, self-consistent entry of another scene put in this scene's folder, then its
    manifest and model.json edited to claim this key: each step is caught."""
    import shutil

    entry = _fill(root)
    compile_scene(load_scene(SCENE, ["bodies.rod.transverse_modes=2"]))
    (other,) = [p for p in (root / "models").iterdir() if p != entry]

    def plant(edit_manifest: bool, edit_meta: bool) -> None:
        shutil.rmtree(entry)
        shutil.copytree(other, entry)
        manifest = json.loads((entry / "manifest.json").read_text())
        if edit_meta:
            meta = json.loads((entry / "model.json").read_text())
            meta["key"] = entry.name
            blob = json.dumps(meta).encode()
            (entry / "model.json").write_bytes(blob)
            # a writer that holds the key (a bug, not an attacker): every file sealed for this entry
            manifest["files"] = {
                name: cache.seal(f"models/{entry.name}/{name}", (entry / name).read_bytes())
                for name in manifest["files"]
            }
        if edit_manifest:
            manifest["key"] = entry.name
        (entry / "manifest.json").write_text(json.dumps(manifest))

    for edit_manifest, edit_meta, expect in (
        (False, False, f"manifest.json is for structure key '{other.name}'"),
        # the keyed hashes are bound to the entry they were written for
        (True, False, "phi.casadi does not match the keyed hash"),
        (True, True, "its structure does not hash to the key"),
    ):
        plant(edit_manifest, edit_meta)
        capsys.readouterr()
        compiled = _recompile(capsys, expect)
        _assert_equal(compiled, reference)


# ----------------------------------------------------------------------------- entries of another version
@pytest.mark.parametrize("field, value", [("format_version", 3), ("symgen", "0.0.1"), ("casadi", "0.0.1")])
def test_an_entry_an_upgrade_left_behind_is_rederived_quietly(root, capsys, reference, field, value):
    """An entry written by an older cache format, symgen or CasADi is not damage: it is derived
    anew and overwritten with no warning (a user's first run after an upgrade writes a clean
    stderr, which the CLI's tests assert), and the next run reads the new entry."""
    entry = _fill(root)
    manifest = json.loads((entry / "manifest.json").read_text())
    (entry / "manifest.json").write_text(json.dumps(dict(manifest, **{field: value})))
    compiled = _recompile(capsys, None)
    assert not compiled.cached
    _assert_equal(compiled, reference)
    assert json.loads((entry / "manifest.json").read_text())[field] == manifest[field]
    again = _recompile(capsys, None)
    assert again.cached
    _assert_equal(again, reference)


# ----------------------------------------------------------------------------- swapped functions
def test_swapped_function_files_are_rederived(root, capsys, reference):
    entry = _fill(root)
    phi, phid = (entry / "phi.casadi").read_bytes(), (entry / "phid.casadi").read_bytes()
    (entry / "phi.casadi").write_bytes(phid)
    (entry / "phid.casadi").write_bytes(phi)
    compiled = _recompile(capsys, "phi.casadi does not match the keyed hash")
    _assert_equal(compiled, reference)

    # swapped together with their keyed hashes in the manifest: each hash is bound to its file's name
    manifest = json.loads((entry / "manifest.json").read_text())
    res, out = (entry / "res.casadi").read_bytes(), (entry / "out.casadi").read_bytes()
    (entry / "res.casadi").write_bytes(out)
    (entry / "out.casadi").write_bytes(res)
    files = manifest["files"]
    files["res.casadi"], files["out.casadi"] = files["out.casadi"], files["res.casadi"]
    (entry / "manifest.json").write_text(json.dumps(manifest))
    compiled = _recompile(capsys, "res.casadi does not match the keyed hash")
    _assert_equal(compiled, reference)


def test_function_of_another_model_is_rederived(root, capsys, reference):
    """A ``res`` of the same name but another model (two transverse modes): sizes differ."""
    entry = _fill(root)
    bigger = compile_scene(load_scene(SCENE, ["bodies.rod.transverse_modes=2"]), use_cache=False)
    capsys.readouterr()
    blob = bigger.funcs["res"].serialize().encode()
    (entry / "res.casadi").write_bytes(blob)
    manifest = json.loads((entry / "manifest.json").read_text())
    manifest["files"]["res.casadi"] = cache.seal(f"models/{entry.name}/res.casadi", blob)  # a keyed writer
    (entry / "manifest.json").write_text(json.dumps(manifest))
    compiled = _recompile(capsys, "res.casadi has sizes")
    _assert_equal(compiled, reference)


# ----------------------------------------------------------------------------- writers
def _race_child(cache_dir: str, barrier, results) -> None:
    os.environ["SYMGEN_CACHE_DIR"] = cache_dir
    real_install = cache.install_dir

    installed = []

    def install_together(tmp, target, replace):
        barrier.wait(timeout=60)  # both writers have a complete temporary entry: race the rename
        installed.append(real_install(tmp, target, replace))
        return installed[-1]

    cache.install_dir = install_together
    scene = load_scene(SCENE)
    compiled = compile_scene(scene)
    results.put((installed, _numbers(compiled, scene)))


def test_concurrent_writers_leave_one_entry_and_no_temp_dirs(root, reference):
    ctx = mp.get_context("spawn")
    barrier, results = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_race_child, args=(str(root), barrier, results)) for _ in range(2)]
    for p in procs:
        p.start()
    got = [results.get(timeout=240) for _ in procs]
    for p in procs:
        p.join(timeout=60)
        assert p.exitcode == 0
    assert sorted(installed for installed, _ in got) == [[False], [True]]  # one won, one lost
    for _, numbers in got:
        for name in reference:
            np.testing.assert_allclose(numbers[name], reference[name], rtol=1e-12, atol=1e-12, err_msg=name)
    assert len([p for p in (root / "models").iterdir()]) == 1
    _no_temp(root)
    compiled = compile_scene(load_scene(SCENE))
    assert compiled.cached
    _assert_equal(compiled, reference)


def test_interrupted_or_losing_writer_removes_its_temp_dir(root, monkeypatch):
    compiled = compile_scene(load_scene(SCENE))
    entry = _entry(root)
    # a writer that finds the entry installed by another keeps that one
    assert casadi_io.save(compiled.funcs, compiled.info, entry) is False
    _no_temp(root)

    def interrupted(tmp, target, replace):
        raise KeyboardInterrupt

    monkeypatch.setattr(cache, "install_dir", interrupted)
    with pytest.raises(KeyboardInterrupt):
        casadi_io.save(compiled.funcs, compiled.info, entry, replace=True)
    _no_temp(root)
    monkeypatch.undo()

    # temporaries of a killed writer: swept on the next write once stale, kept while young
    stale, young = root / "models" / ".tmp-abc-stale", root / "models" / ".tmp-abc-young"
    for d in (stale, young):
        d.mkdir()
        (d / "res.casadi").write_text("half written")
    old = time.time() - cache.STALE_TEMP_S - 60
    os.utime(stale, (old, old))
    assert casadi_io.save(compiled.funcs, compiled.info, entry, replace=True) is True
    assert not stale.exists() and young.exists()
    assert casadi_io.load(entry)[1] == compiled.info


# ----------------------------------------------------------------------------- cli
def test_cache_info_and_clear(root, capsys, tmp_path):
    _fill(root)
    (root / "shapes" / "v2__axial-x__transverse-y.pkl").write_bytes(b"old pickle")
    (root / "models" / ".tmp-dead-123").mkdir()
    foreign = [root / "notes.txt", root / "models" / "README", root / "shapes" / "mine.json"]
    for f in foreign:
        f.write_text("not symgen's")

    assert main(["cache", "info"]) == 0
    out = capsys.readouterr().out
    assert str(root) in out and "$SYMGEN_CACHE_DIR" in out
    assert "models        1 entry" in out and "old           1 entry" in out and "temporary" in out

    assert main(["cache", "clear"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("removed ") and str(root) in out
    left = sorted(str(p.relative_to(root)) for p in root.rglob("*"))
    assert left == ["models", "models/README", "notes.txt", "shapes", "shapes/mine.json"]

    assert main(["cache", "info"]) == 0
    assert "total         0 entries" in capsys.readouterr().out
    assert not compile_scene(load_scene(SCENE)).cached  # and the cache fills again


# ----------------------------------------------------------------------------- expression trees
def test_expression_trees_round_trip_and_reject_anything_else():
    x = sympy.Symbol("xi", real=True)
    y = sympy.Symbol("y")
    exprs = [
        sympy.Rational(-7, 15) * sympy.pi**-3 + 2,
        sympy.Float("-1.25e-40", 50) * x**3,
        sympy.sin(x) * sympy.exp(y) + sympy.cosh(2 * x) - sympy.E**2 + sympy.log(3) * sympy.tan(y),
        sympy.Integer(10) ** 80 + sympy.sqrt(2),
        sympy.Float(0, 30),
    ]
    for e in exprs:
        tree = json.loads(json.dumps(exprdata.encode(e)))
        back = exprdata.decode(tree)
        assert back == e and sympy.srepr(back) == sympy.srepr(e)
    for bad in (
        ["fn", "__import__", ["int", "1"]],
        ["sym", "a b", True],
        ["int", "1+1"],
        ["int", 5],
        ["rat", "1", "0"],
        ["float", 0, "zz", 0, 53],
        ["float", 0, "ff", 10**9, 53],
        ["const", "oo"],
        ["add", ["int", "1"]],
        ["pow", ["int", "2"]],
        "sin(x)",
        [],
        ["eval", "1"],
        ["mul"] + [["int", "1"]] * 2 + [["fn", "open", ["int", "0"]]],
    ):
        with pytest.raises(ValueError):
            exprdata.decode(bad)
    deep = ["int", "1"]
    for _ in range(exprdata.MAX_DEPTH + 2):
        deep = ["pow", deep, ["int", "1"]]
    with pytest.raises(ValueError):
        exprdata.decode(deep)
    with pytest.raises(ValueError):
        exprdata.encode(sympy.Function("f")(x))


def test_read_bytes_refuses_a_folder_as_an_entry(tmp_path):
    """A folder planted where a cache file is expected is an invalid entry (os.fdopen raised
    IsADirectoryError, an internal error of simulate for compiled/<entry>/model.so)."""
    (tmp_path / "model.so").mkdir()
    with pytest.raises(cache.InvalidEntry, match="is not a regular file"):
        cache.read_bytes(tmp_path / "model.so", 1 << 20)
    fd = os.open(tmp_path, os.O_RDONLY)
    try:
        with pytest.raises(cache.InvalidEntry, match="is not a regular file"):
            cache.read_bytes("model.so", 1 << 20, dir_fd=fd)
    finally:
        os.close(fd)


def test_a_cache_warning_names_the_entry_once(root, capsys):
    """The reasons of ``read_bytes`` do not name the file: the warning that reports them does, once
    (a remembered check that is a folder, a compiled entry's manifest that is one)."""
    question = {"check": "names once", "version": 1}
    path, _ = cache._check_path(question)
    path.mkdir(parents=True)
    assert cache.recall(question) == (False, None)
    err = capsys.readouterr().err
    assert err.count(path.name) == 1 and f"cache entry {path} is not a regular file" in err, err
    where = root / "compiled" / "entry"
    (where / compiled.MANIFEST).mkdir(parents=True)
    with pytest.raises(cache.InvalidEntry) as exc:
        compiled.read_verified(where, {})
    assert exc.value.reason == f"{compiled.MANIFEST} is not a regular file"


# ----------------------------------------------------------------------------- lazy Functions
def test_lazy_functions_are_checked_when_read(root, capsys, reference):
    """``compile_scene(lazy=True)`` (a ``--solver c`` run: its library holds the model) checks the
    entry's keyed hashes at once and CasADi's reading of the Functions on first use: a flipped
    bit is re-derived at the load, as without ``lazy``; a Function this CasADi does not read
    (another CasADi's entry, the manifest's version) is a clear error naming the entry, which is
    removed, and the next load derives it anew."""
    from symgen.errors import SceneError

    entry = _fill(root)
    lazy = compile_scene(load_scene(SCENE), lazy=True)
    assert lazy.cached and isinstance(lazy.funcs, casadi_io.LazyFunctions)
    _assert_equal(lazy, reference)

    _flip_bit(entry / "res.casadi")
    S.clear_memory_cache()
    compiled = compile_scene(load_scene(SCENE), lazy=True)
    assert not compiled.cached and "res.casadi does not match the keyed hash" in capsys.readouterr().err
    _assert_equal(compiled, reference)

    manifest = json.loads((entry / "manifest.json").read_text())
    (entry / "manifest.json").write_text(json.dumps(dict(manifest, casadi="0.0.1")))
    stale = compile_scene(load_scene(SCENE), lazy=True)  # the version is read with the Functions
    assert stale.cached
    with pytest.raises(SceneError, match="written by CasADi '0.0.1'") as err:
        stale.funcs["res"]
    assert str(entry) in str(err.value) and not entry.exists()
    again = compile_scene(load_scene(SCENE), lazy=True)
    assert not again.cached
    _assert_equal(again, reference)
