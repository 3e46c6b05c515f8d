"""Both edges of a ring electrode (coexist.shapes, ``coexist shape``): a ring (R/A 0.4 to 0.9, two-layer passive
regions, the audit scene of the ring tests) begins and ends inside the zone, so its profile has two electrode edges,
its inner one (R/A 0.4) and its outer one (R/A 0.9). Before, the profile, the table, the JSON and the figures kept
only the inner edge. A uniform electrode still has one edge, the clamp.

Measured (one zone at 0 and 6 kV, 25 mbar closing pressure, 300 ml): inner edge (11.3415, 17.6782) and
(11.0646, 18.4058) mm, outer edge (21.6942, 2.5103) and (21.9175, 2.3425) mm. The outer edge lies *outside* the
clamp radius (λpre A = 21.4165 mm): the inflated cap bulges past its clamp below its equator.
"""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import ring_scene

from coexist.cli.main import cli
from coexist.scene import load_scene
from coexist.shapes import patterned_profiles, profiles, scene_zone_path

FI, FO = 0.4, 0.9
VOLTAGES_KV = (0.0, 6.0)


def run(*args):
    r = CliRunner().invoke(cli, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r


@pytest.fixture(scope="module")
def ring1(tmp_path_factory):
    path = tmp_path_factory.mktemp("ring_edges") / "ring1.toml"
    path.write_text(ring_scene("tension-field", name="ring1", fi=FI, fo=FO, count=1, path="[0, 6.3]"), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def ring1_json(ring1):
    kv = ",".join(f"{v:g}" for v in VOLTAGES_KV)
    return json.loads(run("shape", ring1, "--voltage-kV", kv, "--json").stdout)


@pytest.fixture(scope="module")
def ring1_profiles(ring1):
    sc = load_scene(str(ring1))
    path, _ = scene_zone_path(sc, [float(sc.phi_hat(v * 1e3)) for v in VOLTAGES_KV])
    assert path.phi_hat.size == len(VOLTAGES_KV)
    profs = patterned_profiles(
        sc.model(), sc.zone_pattern(), path.pole_stretch, path.phi_hat, zone_radius=sc.zone_radius, points=201
    )
    return sc, profs


def test_ring_json_has_both_edges_inner_then_outer(ring1_json):
    clamp_mm = ring1_json["zone_radius_mm"]  # prestretch 1
    for entry in ring1_json["voltages"]:
        (g,) = entry["groups"]
        edges = g["electrode_edges_mm"]
        assert len(edges) == 2, edges
        (ri, zi), (ro, zo) = edges
        assert g["electrode_edge_mm"] == [ri, zi]  # the first edge, as before: the inner one
        # the outer edge lies further out than the inner one and lower (z falls outward on the inflated cap), above
        # the clamp plane, and no further out than the profile's widest point (here it is past the clamp radius)
        assert 0 < ri < ro <= max(g["profile"]["r_mm"]) * (1 + 1e-12)
        assert zi > zo > 0
        assert zi < g["apex_height_mm"]
        assert ro > ri + 0.3 * clamp_mm


def test_ring_json_edges_lie_on_the_profile_points(ring1_json):
    """The edges are the solver's interface points; the profile is integrated again, with the interfaces among its
    points: each edge is one of them, to 1e-9."""
    for entry in ring1_json["voltages"]:
        (g,) = entry["groups"]
        r, z = np.array(g["profile"]["r_mm"]), np.array(g["profile"]["z_mm"])
        scale = ring1_json["zone_radius_mm"]
        for re_, ze in g["electrode_edges_mm"]:
            assert np.min(np.hypot(r - re_, z - ze)) <= 1e-9 * scale, (re_, ze)


def test_ring_profile_edges_at_the_fractions_on_the_points(ring1_profiles):
    sc, profs = ring1_profiles
    for p in profs:
        assert len(p.electrode_edges_hat) == 2
        (Ri, ri, zi), (Ro, ro, zo) = p.electrode_edges_hat
        assert abs(Ri - FI) <= 1e-12 and abs(Ro - FO) <= 1e-12
        assert p.electrode_edge_R_hat == Ri and p.electrode_edge_hat == (ri, zi)
        for R_e, r_e, z_e in p.electrode_edges_hat:  # independent: the re-integrated profile's point at R̂ = f
            (k,) = np.flatnonzero(p.R_hat == R_e)
            assert r_e == pytest.approx(p.r_hat[k], rel=1e-9, abs=0)
            assert z_e == pytest.approx(p.z_hat[k], rel=1e-9, abs=0)
        assert ri < ro and zi > zo > 0
        # in metres, as the JSON reports them
        assert p.electrode_edges[1] == pytest.approx((ro * sc.zone_radius, zo * sc.zone_radius), rel=1e-15)
        assert p.to_dict(points=False)["electrode_edges_mm"][1] == pytest.approx(
            [ro * sc.zone_radius * 1e3, zo * sc.zone_radius * 1e3]
        )


def test_ring_table_prints_both_edges(ring1):
    out = run("shape", ring1, "--voltage-kV", "0,6").stdout
    lines = out.splitlines()
    assert "electrode_edges_mm (r, z)" in lines[0]
    rows = [ln for ln in lines if re.match(r"\s+\d+\.\d{3}\s+1\s", ln)]
    assert len(rows) == 2
    pair = r"\((\d+\.\d{4}), (\d+\.\d{4})\)"
    for ln in rows:
        found = re.findall(pair, ln)
        assert len(found) == 2, ln
    # the edge column is as wide as its header: the rows' edges end where the header's title does
    col_end = lines[0].index("  configuration")
    assert all(ln[col_end - 1] == ")" and ln[col_end : col_end + 2] == "  " for ln in rows)
    assert "(11.3415, 17.6782) (21.6942, 2.5103)" in rows[0]


def test_uniform_zone_has_one_edge_the_clamp():
    sc = load_scene("tricircle")
    clamp_mm = sc.prestretch * sc.zone_radius * 1e3
    data = json.loads(run("shape", "--voltage-kV", "0,4.0", "--points", "21", "--json").stdout)
    for entry in data["voltages"]:
        for g in entry["groups"]:
            assert g["electrode_edges_mm"] == [g["electrode_edge_mm"]]
            assert g["electrode_edges_mm"][0] == [pytest.approx(clamp_mm, rel=1e-12), 0.0]
    (p,) = profiles(sc.model(), [1.3], 0.0, zone_radius=sc.zone_radius, points=21)
    assert p.electrode_edges_hat == ((1.0, sc.prestretch, 0.0),)


def test_side_view_marks_every_edge_and_fits_every_zone(tmp_path, monkeypatch):
    """Three ring zones (R/A 0.2 to 0.8), one bulged at 4 kV, its meridian wider than its clamp: every zone inside
    the panel, none overlapping its neighbour, and two edge ticks on each side of each zone (before: one, and the
    bulged zone cut off by the panel's edge)."""
    import coexist.plotting as plotting

    scene = tmp_path / "r28.toml"
    scene.write_text(ring_scene("tension-field", "r28_p23", 0.2, 0.8, 3, 23, "[0, 3.2, 4.1, 3.2]"), encoding="utf-8")
    figs = []
    real = plotting.save_figure

    def keep(fig, path, *args, **kwargs):
        figs.append(fig)
        return real(fig, path, *args, **kwargs)

    monkeypatch.setattr(plotting, "save_figure", keep)
    run("shape", scene, "--voltage-kV", "4.0", "-o", tmp_path / "r28.png")
    (fig,) = figs
    (ax,) = fig.axes
    x_lo, x_hi = ax.get_xlim()
    outlines = [ln for ln in ax.lines if ln.get_marker() in ("None", None, "") and len(ln.get_xdata()) > 10]
    assert len(outlines) == 3
    spans = sorted((float(np.min(ln.get_xdata())), float(np.max(ln.get_xdata()))) for ln in outlines)
    assert x_lo < spans[0][0] and spans[-1][1] < x_hi
    assert all(a[1] < b[0] for a, b in zip(spans, spans[1:]))
    ticks = [ln for ln in ax.lines if ln.get_marker() == "|"]
    assert len(ticks) == 3 * 2  # per zone one line of two ticks (both sides) per edge
    assert "electrode edges" in ax.get_title()
