"""A ring electrode (R/A 0.4 to 0.9, two-layer passive regions) on a tension-field scene: where its states stop,
the continuation's failed corrector can report a pole stretch outside the physical range (status -1), which
crashed the ramp with an internal KeyError (audit helper-48). The ramp ends there, at the voltage where the
same scene with wrinkling refused ends (the hoop tension at the ring's inner edge vanishing: 6.36497247 kV)."""

from click.testing import CliRunner
from conftest import ring_scene

from coexist.cli.main import cli
from coexist.continuation import _is_pull_in
from coexist.shooting import PULL_IN


def test_status_minus_one_is_no_pull_in():
    assert not _is_pull_in(-1) and _is_pull_in(PULL_IN) and not _is_pull_in(0)


def test_ring_on_tension_field_ends_where_the_refused_scene_ends(tmp_path):
    import json

    ends = {}
    for mode in ("tension-field", "refuse"):
        path = tmp_path / f"{mode}.toml"
        path.write_text(ring_scene(mode, "one_ring"))
        r = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
        assert r.exit_code == 0, r.output
        (t,) = [t for t in json.loads(r.stdout)["transitions"] if t["kind"] == "no_stable_state"]
        ends[mode] = (t["voltage_kV"], t["voltage_error_kV"])
    (a, ea), (b, eb) = ends["tension-field"], ends["refuse"]
    assert abs(a - 6.36497247) < 2e-8 and abs(a - b) <= ea + eb + 1e-9
