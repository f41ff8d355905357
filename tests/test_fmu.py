"""The FMI 2.0 Co-Simulation FMU (symgen emit-fmu), checked with FMPy, a third-party client.

FMPy is a test extra (``pip install -e '.[test]'``); without it these tests are skipped.
"""

from __future__ import annotations

import subprocess
import zipfile

import numpy as np
import pytest

from c_support import EXAMPLES, WORK, closure_columns, context, idas_reference, mechanism, needs_cc, needs_cxx

from symgen.ir.physical import physical_map

fmpy = pytest.importorskip("fmpy", reason="fmpy is not installed (pip install fmpy, or pip install -e '.[test]')")

pytestmark = needs_cc


def _fmu(name: str):
    path = WORK / f"{name}.fmu"
    if not path.exists():
        from symgen.backends.fmu import write_fmu

        mech = mechanism(name)
        write_fmu(mech.scene, path, context(name))
    return path


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_fmpy_validates_the_fmu(name):
    from fmpy.validation import validate_fmu

    path = _fmu(name)
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    scene = mechanism(name).scene
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    params = [v.name for v in md.modelVariables if v.causality == "parameter"]
    assert outputs == [o.name for o in scene.outputs]
    # the model's parameters, then (an SI scene) its physical inputs in SI (symgen.ir.physical)
    physical = [k for k, _ in physical_map(scene).inputs]
    assert bool(physical) == (scene.units == "SI")
    assert params == list(mechanism(name).info.params) + physical
    assert md.coSimulation.modelIdentifier == name
    with zipfile.ZipFile(path) as zf:
        names = set(zf.namelist())
    assert {
        f"binaries/linux64/{name}.so",
        f"sources/{name}_fmi2.c",
        f"sources/{name}_jac.c",
        f"sources/{name}_solver.c",
        "sources/fmi2Functions.h",
        "modelDescription.xml",
    } <= names


def test_fmpy_simulates_the_slider_crank_like_idas():
    """Two crank turns with FMPy's co-simulation master at the FMU's default experiment
    (the scene's tolerance): within 1e-4 of each output's peak of the converged IDAS run."""
    name = "slider_crank"
    tau, ref = idas_reference(name)
    res = fmpy.simulate_fmu(str(_fmu(name)))
    got = np.column_stack([res[k] for k in res.dtype.names[1:]])
    assert list(res.dtype.names[1:]) == list(mechanism(name).info.outputs)
    assert len(res) == len(tau)
    np.testing.assert_allclose(res["time"], tau, atol=1e-9)
    for k in range(ref.shape[1]):
        if k in closure_columns(name):
            assert np.abs(got[:, k]).max() < 1e-12
            continue
        peak = np.abs(ref[:, k]).max()
        assert np.abs(got[:, k] - ref[:, k]).max() < 1e-4 * peak, res.dtype.names[1 + k]


def test_fmu_parameters_are_settable_and_outputs_are_not():
    path = str(_fmu("slider_crank"))
    res = fmpy.simulate_fmu(path, stop_time=0.5, output_interval=0.25, start_values={"lambda_rod": 9000.0})
    assert len(res) == 3 and np.all(np.isfinite(res["eta_mid"]))
    with pytest.raises(Exception):  # noqa: B017 - fmpy raises its own exception types for this
        fmpy.simulate_fmu(path, stop_time=0.5, start_values={"eta_mid": 1.0})


@needs_cxx
def test_fmu_wrapper_compiles_strict_c99_and_cxx():
    name = "slider_crank"
    folder = WORK / "fmu_src"
    with zipfile.ZipFile(_fmu(name)) as zf:
        zf.extractall(folder)
    src = folder / "sources" / f"{name}_fmi2.c"
    for cmd in (
        ["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1"],
        ["g++", "-x", "c++", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1"],
    ):
        proc = subprocess.run(
            [*cmd, f"-I{folder / 'sources'}", "-c", str(src), "-o", str(WORK / "fmi2.o")],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 0, proc.stderr


def test_cli_emit_fmu(tmp_path):
    from symgen.cli import main

    out = tmp_path / "sc.fmu"
    assert main(["emit-fmu", str(EXAMPLES["slider_crank"]), "-o", str(out)]) == 0
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(out)) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sc.fmu"]  # no temporary left


def test_fmu_variable_names_stay_unique_when_an_output_is_named_like_a_parameter():
    import dataclasses
    import xml.etree.ElementTree as ET

    from symgen.backends.fmu import fmu_files

    scene = mechanism("slider_crank").scene
    outputs = list(scene.outputs)
    outputs[0] = dataclasses.replace(outputs[0], name="rate")  # "rate" is also a parameter
    renamed = dataclasses.replace(scene, outputs=tuple(outputs))
    xml = fmu_files(renamed, context("slider_crank"))["modelDescription.xml"]
    root = ET.fromstring(xml.encode())
    names = [v.get("name") for v in root.iter("ScalarVariable")]
    assert len(names) == len(set(names)) and "rate" in names and "parameter_rate" in names
    exp = root.find("DefaultExperiment")
    assert float(exp.get("stopTime")) == pytest.approx(scene.simulation.t_end)
    assert float(exp.get("tolerance")) == scene.simulation.rtol


def _umask() -> int:
    import os

    old = os.umask(0)
    os.umask(old)
    return old


def test_fmu_rejects_invalid_parameters_and_has_the_mode_of_any_output():
    """fmi2SetReal refuses a non-finite or out-of-range parameter (fmi2Error, a logged message
    naming the parameter and its range from symgen.ir.parameters.parameter_records); the .fmu file
    has the mode open() gives (0666 & ~umask), not mkstemp's 0600."""
    import os
    import xml.etree.ElementTree as ET

    path = _fmu("slider_crank")
    assert os.stat(path).st_mode & 0o777 == 0o666 & ~_umask()
    messages = []
    for value in (-1.0, 0.0, float("nan"), float("inf")):
        with pytest.raises(Exception, match="fmi2SetReal"):
            fmpy.simulate_fmu(
                str(path),
                stop_time=0.1,
                start_values={"lambda_rod": value},
                logger=lambda *args: messages.append(args[-1].decode()),
            )
    assert len(messages) == 4
    assert all("not a valid value of the parameter lambda_rod: it must be > 0" in m for m in messages), messages
    with zipfile.ZipFile(path) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    real = {v.get("name"): v.find("Real") for v in root.iter("ScalarVariable")}
    assert (real["dx_B"].get("min"), real["dx_B"].get("max")) == ("-1.0", "1.0")  # closed range
    assert real["lambda_rod"].get("min") is None  # > 0: not expressible
