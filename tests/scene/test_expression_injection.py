"""Scene files are data: no route from a scene (or a ``--set`` override) runs code.

Each payload would, if evaluated by Python or SymPy, create a file (in the working directory and
at an absolute path). Every route a string from the user takes (load and torque expressions in
the file, ``--set`` on them or on the whole driver, output/body/joint names) and every command
that reads a scene must end in exit 2 with a message naming the file and the key, with no output
written and no file created. A valid expression in the same place is accepted (the route is live).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from symgen.cli import main
from symgen.scene import load_scene

DATA = Path(__file__).parent / "data"
SCENE_TEXT = (DATA / "slider_crank.toml").read_text(encoding="utf-8")
LOAD = '"0.1*sin(tau)"'
assert SCENE_TEXT.count(LOAD) == 1
DRIVER = re.compile(r'\[driver\]\nkind = "angle"\n')
assert DRIVER.search(SCENE_TEXT) and 'M0 = { kind = "driver_torque" }\n' in SCENE_TEXT


def payloads(marker: Path) -> list[str]:
    """Strings that run code (touch PWNED here and ``marker``) if anything evaluates them."""
    touch = f'__import__("pathlib").Path({str(marker)!r}).touch()'
    system = "__import__('os').system('touch PWNED')"
    return [
        f"0*sin('{touch}')",  # string arguments went to sympify
        f'0*cos("{system}")',
        f"exp('{touch}')*0",
        f"log('{touch}')",
        f"sqrt('{touch}')",
        f"Abs('{touch}')",
        f"Heaviside('{touch}')",
        f"0 and {touch}",  # evaluated at parse time
        f"1 if {touch} else 0",
        f"(lambda: {touch})()",
        system,
        f"[{touch} for x in (1,)]",
        "().__class__.__base__.__subclasses__()",
        f"Symbol('x').__class__.__init__.__globals__['__builtins__']['exec']('{system}')",
        "9**9**9**9",  # hung SymPy's parser
    ]


def _toml_string(text: str) -> str:
    return json.dumps(text)  # a JSON string of ASCII text is a TOML basic string


def torque_scene(value: str) -> str:
    """The valid slider-crank with a torque driver of the given value (TOML text)."""
    text = SCENE_TEXT.replace('M0 = { kind = "driver_torque" }\n', "")  # an angle driver's output
    return DRIVER.sub(f'[driver]\nkind = "torque"\nvalue = {_toml_string(value)}\n', text)


def load_scene_text(value: str) -> str:
    return SCENE_TEXT.replace(LOAD, _toml_string(value))


@pytest.fixture
def sandbox(tmp_path, monkeypatch):
    """A scene folder, an output folder and a working directory, all empty; the marker path."""
    for sub in ("scenes", "out", "cwd"):
        (tmp_path / sub).mkdir()
    monkeypatch.chdir(tmp_path / "cwd")
    return tmp_path


def _assert_refused(code: int, err: str, sandbox: Path, file: str, key: str) -> None:
    assert code == 2, err
    assert file in err and key in err, err
    assert "Traceback" not in err and "internal error" not in err
    assert list((sandbox / "out").iterdir()) == [], "an output was written"
    assert list((sandbox / "cwd").iterdir()) == [], "the payload ran (a file appeared)"
    assert not (sandbox / "PWNED").exists(), "the payload ran"


def test_the_routes_are_live(sandbox):
    """A valid expression in each place loads (so the refusals below come from the parser)."""
    for text in (load_scene_text("0.2*cos(2*tau)"), torque_scene("0.5*Heaviside(tau - 1)")):
        path = sandbox / "scenes" / "ok.toml"
        path.write_text(text, encoding="utf-8")
        load_scene(path)


@pytest.mark.parametrize("route", ["load", "torque"])
def test_expressions_in_the_scene_file(sandbox, capsys, route):
    marker = sandbox / "PWNED"
    for i, payload in enumerate(payloads(marker)):
        scene = sandbox / "scenes" / f"{route}{i}.toml"
        scene.write_text(load_scene_text(payload) if route == "load" else torque_scene(payload), encoding="utf-8")
        code = main(["simulate", str(scene), "-o", str(sandbox / "out" / "r.csv")])
        key = "loads[0].transverse" if route == "load" else "driver.value"
        _assert_refused(code, capsys.readouterr().err, sandbox, str(scene), key)


def test_expressions_through_set_overrides(sandbox, capsys):
    marker = sandbox / "PWNED"
    loads = sandbox / "scenes" / "loads.toml"
    loads.write_text(SCENE_TEXT, encoding="utf-8")
    torque = sandbox / "scenes" / "torque.toml"
    torque.write_text(torque_scene("0.5"), encoding="utf-8")
    for payload in payloads(marker):
        cases = [
            (loads, f"loads[0].transverse={payload}", "loads[0].transverse"),
            (loads, f"loads.1.axial={payload}", "loads[1].axial"),
            (torque, f"driver.value={payload}", "driver.value"),
            (loads, f'driver={{kind = "torque", body = "crank", value = {_toml_string(payload)}}}', "driver.value"),
        ]
        for scene, override, key in cases:
            code = main(["simulate", str(scene), "-o", str(sandbox / "out" / "r.csv"), "--set", override])
            _assert_refused(code, capsys.readouterr().err, sandbox, str(scene), key)


@pytest.mark.parametrize(
    "command",
    [
        ["simulate", "-o", "{out}/r.csv"],
        ["quasistatic", "-o", "{out}/r.csv"],
        ["latex", "-o", "{out}/m.tex"],
        ["modes", "-o", "{out}/m.json"],
        ["emit-c", "-o", "{out}/c"],
        ["emit-fmu", "-o", "{out}/m.fmu"],
        ["effects", "--auto", "1e-3", "-o", "{out}/pruned.toml"],
        ["study", "--quick", "-o", "{out}/study"],
        ["derive", "-o", "{out}/generated"],
    ],
)
def test_every_command_refuses_the_payload(sandbox, capsys, command):
    scene = sandbox / "scenes" / "scene.toml"
    scene.write_text(load_scene_text(payloads(sandbox / "PWNED")[0]), encoding="utf-8")
    argv = [command[0], str(scene)] + [a.format(out=sandbox / "out") for a in command[1:]]
    code = main(argv)
    _assert_refused(code, capsys.readouterr().err, sandbox, str(scene), "loads[0].transverse")


@pytest.mark.parametrize(
    "where,key",
    [
        ("output", "outputs."),
        ("body", "bodies[0].name"),
        ("joint", "joints[0].name"),
    ],
)
def test_names_are_identifiers_not_code(sandbox, capsys, where, key):
    payload = "__import__('os').system('touch PWNED')"
    text = SCENE_TEXT
    if where == "output":
        text = text.replace("[outputs]\n", f'[outputs]\n{_toml_string(payload)} = {{ kind = "energy" }}\n')
    elif where == "body":
        text = text.replace('name = "crank"', f"name = {_toml_string(payload)}", 1)
    else:
        text = text.replace('name = "O"', f"name = {_toml_string(payload)}", 1)
    assert text != SCENE_TEXT
    scene = sandbox / "scenes" / f"{where}.toml"
    scene.write_text(text, encoding="utf-8")
    code = main(["simulate", str(scene), "-o", str(sandbox / "out" / "r.csv")])
    _assert_refused(code, capsys.readouterr().err, sandbox, str(scene), key)
    code = main(
        [
            "simulate",
            str(DATA / "slider_crank.toml"),
            "-o",
            str(sandbox / "out" / "r.csv"),
            "--set",
            f'outputs.{payload}={{kind = "energy"}}',
        ]
    )
    _assert_refused(code, capsys.readouterr().err, sandbox, str(DATA / "slider_crank.toml"), "outputs.")


def test_effects_auto_header_cannot_add_toml():
    """``symgen effects --auto`` writes the scene's file name in a comment: a name with a newline
    (or another control character) stays inside the comment."""
    import tomllib

    from symgen.apps.effects import toml_text

    raw = {"scene": {"name": "s"}, "effects": {"coriolis": True}}
    text = toml_text(raw, "from evil\n[effects]\ncoriolis = false\r\x7f.toml")
    assert tomllib.loads(text) == raw and text.splitlines()[0].startswith("# from evil?[effects]")
