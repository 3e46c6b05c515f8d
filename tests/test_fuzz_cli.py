"""Fuzzing the command line: generated scenes (valid and broken, huge and tiny values) and option strings,
run in-process through click's CliRunner under a time budget. Every run must exit 0, 1 or 2, show no
traceback, print no NaN, and write no file it was not asked to.

CI runs a small budget (``COEXIST_FUZZ_EXAMPLES``, default 40 examples, about 15 s); a longer run:
``COEXIST_FUZZ_EXAMPLES=500 pytest tests/test_fuzz_cli.py``.
"""

import os
import re

import pytest
from click.testing import CliRunner
from conftest import time_limit
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from coexist.cli.main import cli

EXAMPLES = int(os.environ.get("COEXIST_FUZZ_EXAMPLES", "40"))
#: wall-clock limit of one generated run (s): a run that cannot finish in it is a hang or unbounded work
RUN_LIMIT = 60.0

NUMBERS = st.one_of(
    st.sampled_from([0, -1, 1e-30, 1e-9, 1e-3, 0.5, 1, 2, 3, 97, 1e3, 1e6, 1e30, 1e300]),
    st.floats(min_value=1e-3, max_value=1e3, allow_nan=False),
)
ODD = st.sampled_from(['"x"', "true", "nan", "inf", "-inf", "[1, 2]", '"1e-3"', "1e999", "{a = 1}"])


@st.composite
def scenes(draw, voltage=None):
    """A scene text: a plausible experiment, then up to two mutations of its values."""
    gent = draw(st.booleans())
    membrane = {
        "material": '"gent"' if gent else '"neo-hookean"',
        "shear_modulus_kPa": draw(st.sampled_from([45, 100, 10])),
        "relative_permittivity": draw(st.sampled_from([4.7, 1, 10])),
        "thickness_mm": 0.5,
        "zone_radius_mm": draw(st.sampled_from([10, 20, 21.4, 30])),
    }
    if gent:
        membrane["jlim"] = draw(st.sampled_from([97, 40, 5, 0.5]))
    doc = {"membrane": membrane, "zones": {"count": draw(st.integers(1, 5))}}
    if draw(st.booleans()):
        closing = draw(st.one_of(st.sampled_from([5, 10, 20, 30]), NUMBERS))
        doc["chamber"] = {"volume_ml": draw(st.sampled_from([300, 300, 30, 1e-3])), "closing_pressure_mbar": closing}
    else:
        doc["zones"]["pressure_mbar"] = draw(st.one_of(st.sampled_from([5, 10, 15]), NUMBERS))
    if voltage if voltage is not None else draw(st.booleans()):
        stop = draw(st.sampled_from([0, 1, 4, 4, 5, 8, 50, 1e6]))
        step = draw(st.sampled_from([stop / 10 or 1, stop / 20 or 1, stop / 10 or 1, 1e-9]))
        doc["voltage"] = {"stop_kV": stop, "step_kV": step}
    for _ in range(draw(st.sampled_from([0, 0, 0, 1, 2]))):
        filled = sorted(s for s in doc if doc[s])  # a first mutation may have dropped a section's last key
        if not filled:
            break
        section = draw(st.sampled_from(filled))
        key = draw(st.sampled_from(sorted(doc[section])))
        action = draw(st.sampled_from(["number", "odd", "drop"]))
        if action == "drop":
            del doc[section][key]
        else:
            doc[section][key] = draw(NUMBERS) if action == "number" else draw(ODD)
    lines = []
    if draw(st.booleans()):
        lines.append('name = "fuzz\\u001b[1m"')
    for section, table in doc.items():
        lines.append(f"[{section}]")
        lines += [f"{k} = {v}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


OUTPUTS = st.sampled_from([None] * 6 + ["out.png", "out.svg", "out.csv", "nofolder/out.png", "out", "-"])


@st.composite
def invocations(draw):
    """``(args, stdin, requested files)`` of one command."""
    command = draw(st.sampled_from(["check", "ramp", "coexistence", "curves", "phase-diagram", "shape"]))
    args, stdin, files = [command], None, set()
    if command in ("check", "ramp", "coexistence", "shape"):
        args.append("-")
        stdin = draw(scenes(voltage=True if command in ("ramp", "shape") else None))
    if command == "shape":
        args += ["--voltage-kV", draw(st.sampled_from(["0", "0,2", "0:4:1", "3", "-1", "x", "1e9", "0:5:0", "2,1"]))]
        if draw(st.booleans()):
            args += ["--points", draw(st.sampled_from(["3", "41", "2", "x", "100000"]))]
    if command == "check" and draw(st.booleans()):
        args.append("--no-solve")
    if command in ("ramp", "curves", "phase-diagram", "shape"):
        out = draw(OUTPUTS)
        if out is not None:
            args += ["-o", out]
            files.add(out)
    if command == "ramp" and draw(st.booleans()):
        args += ["--every", draw(st.sampled_from(["1", "5", "5", "0", "x", "100000"]))]
    if command == "coexistence" and draw(st.booleans()):
        args += ["--bulged", draw(st.sampled_from(["1", "1", "2", "0", "1,2", "x", "99"]))]
    if command == "curves":
        args += ["--phi-hat", draw(st.sampled_from(["0.1", "0,0.2", "0.1", "0,0.2", "-1", "nan", "x", "5"]))]
        args += ["--p-hat", draw(st.sampled_from(["none", "1.5", "none", "1.5", "0", "100"]))]
        args += ["--points", draw(st.sampled_from(["3", "20", "20", "20", "2", "x"]))]
        csv = draw(st.sampled_from([None, None, None, "c.csv", "-", "c.png"]))
        if csv is not None:
            args += ["--csv", csv]
            files.add(csv)
    if command == "phase-diagram":
        args += ["--phi-hat", draw(st.sampled_from(["0,0.3", "0,0.3", "0,0.3", "0.3,0", "0,x"]))]
        args += ["--points", draw(st.sampled_from(["3", "5", "5", "5", "1"]))]
        if draw(st.booleans()):
            args += ["--jlim", draw(st.sampled_from(["40", "40", "97", "0.5", "-1", "x"]))]
    if command != "check" and draw(st.sampled_from([False, False, True])):
        args += ["--rtol", draw(st.sampled_from(["1e-6", "1e-8", "1e-8", "1e-20", "x", "nan"]))]
    if draw(st.booleans()):
        args.append("--json")
    return args, stdin, files


@pytest.mark.slow
@settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(invocation=invocations())
def test_every_run_ends_in_an_answer_or_a_clean_error(invocation, tmp_path_factory):
    args, stdin, requested = invocation
    folder = tmp_path_factory.mktemp("fuzz")
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        with time_limit(RUN_LIMIT):
            result = CliRunner().invoke(cli, args, input=stdin)
    finally:
        os.chdir(cwd)
    event(f"{args[0]} exit {result.exit_code}")
    shown = f"coexist {' '.join(args)}\n--- stdin ---\n{stdin}\n--- output ---\n{result.output[-2000:]}"
    assert result.exit_code in (0, 1, 2), shown
    assert result.exception is None or isinstance(result.exception, SystemExit), (repr(result.exception), shown)
    assert "Traceback" not in result.output, shown
    assert not re.search(r"\bnan\b", result.stdout, flags=re.IGNORECASE), shown
    written = {p.name for p in folder.iterdir()}
    assert written <= {os.path.basename(f) for f in requested}, (written, shown)
    if result.exit_code == 2:
        assert "Error:" in result.output, shown
