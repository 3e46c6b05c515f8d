"""Labelled results: curves, ramps and sweeps as :class:`xarray.Dataset` objects, written to netCDF.

Every dimension has its coordinate, every variable its ``units`` (``"1"`` for normalised quantities, whose
``long_name`` gives the normalisation) and ``long_name`` attributes. xarray is imported here, inside the
functions, so the rest of the package and the command line start without it (it is the ``sweep`` extra:
``pip install "coexist[sweep]"``). Missing values are NaN only where a variable says why: a step without a
state has the configuration ``"none"``; a sweep point without a transition has its ``status`` and ``reason``.

netCDF files are written with the ``h5netcdf`` engine (HDF5 through h5py, wheels on PyPI for every platform,
variable-length strings for the status and configuration labels) to a temporary file renamed onto the target.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

#: normalised quantities of one zone (coexist.scene: p̂ = pA/(μH), V̂ = V/A³, Φ̂ = (Φ/H)√(ε/μ), ...)
NORMALISED = {
    "pole_stretch": "pole stretch λ0",
    "phi_hat": "normalised voltage Φ̂ = (Φ/H)√(ε/μ)",
    "p_hat": "normalised gauge pressure p̂ = pA/(μH)",
    "v_hat": "normalised volume V̂ = V/A³",
    "q_hat": "normalised charge Q̂ = Q/(A²√(εμ))",
    "psi_hat": "normalised potential Ψ̂ = Ψ/(μHA²), Ψ = F − ΦQ",
    "apex_height": "pole height above the clamp plane over A",
    "max_field_hat": "largest true field Ê = Φ̂ λ1 λ2 (normalised, E√(ε/μ))",
    "min_tension_hat": "smallest principal tension T̂1, T̂2 (normalised by μH)",
}
#: what every netCDF written here is read back with
ENGINE = "h5netcdf"


def _xr():
    try:
        import xarray as xr
    except ImportError as exc:  # pragma: no cover - the extra is part of the test install
        from .errors import SceneError

        raise SceneError(
            f"labelled results need xarray ({exc}); install the extra: pip install 'coexist[sweep]'", "xarray"
        ) from None
    return xr


def _attrs_safe(attrs: dict) -> dict:
    """netCDF attributes: strings and numbers only (None dropped, booleans as 0/1, others as JSON)."""
    out: dict = {}
    for k, v in attrs.items():
        if v is None:
            continue
        if isinstance(v, bool):
            out[k] = int(v)
        elif isinstance(v, (str, int, float, np.integer, np.floating)):
            out[k] = v
        else:
            out[k] = json.dumps(v, sort_keys=True, default=str)
    return out


def curve_dataset(curve):
    """A :class:`~coexist.curves.Curve` as a dataset: dimension ``state`` (coordinate ``pole_stretch``) and
    ``limit_point`` (coordinate ``limit_kind``).

    Parameters
    ----------
    curve : Curve

    Returns
    -------
    xarray.Dataset
        ``p_hat``, ``v_hat``, ``q_hat``, ``psi_hat``, ``phi_hat``, ``apex_height``, ``max_field_hat``,
        ``min_tension_hat`` over ``state``; the limit points' values and their errors (``limit_p_hat``,
        ``limit_p_hat_error``, ...) over ``limit_point``; attributes
        ``family``, the fixed value (``fixed_phi_hat`` or ``fixed_p_hat``) and ``relative_tolerance``.
    """
    xr = _xr()
    s = curve.states
    arrays = {
        "phi_hat": s.phi_hat,
        "p_hat": s.p_hat,
        "v_hat": s.v_hat,
        "q_hat": s.q_hat,
        "psi_hat": s.psi_hat,
        "apex_height": s.apex_height,
        "max_field_hat": s.max_field,
        "min_tension_hat": s.min_tension,
    }
    data = {
        k: ("state", np.asarray(v, dtype=float), {"units": "1", "long_name": NORMALISED[k]}) for k, v in arrays.items()
    }
    lps = curve.limit_points
    for k in ("pole_stretch", "p_hat", "v_hat", "phi_hat", "q_hat", "psi_hat"):
        data[f"limit_{k}"] = (
            "limit_point",
            np.array([getattr(lp, k) for lp in lps], dtype=float),
            {"units": "1", "long_name": f"at the limit point: {NORMALISED[k]}"},
        )
        data[f"limit_{k}_error"] = (
            "limit_point",
            np.array([np.nan if lp.errors is None else lp.errors[k] for lp in lps], dtype=float),
            {"units": "1", "long_name": f"error of limit_{k}, measured at rtol/100 (NaN: not measured)"},
        )
    coords = {
        "pole_stretch": (
            "state",
            np.asarray(s.pole_stretch, dtype=float),
            {"units": "1", "long_name": NORMALISED["pole_stretch"]},
        ),
        "limit_kind": (
            "limit_point",
            np.array([lp.kind for lp in lps], dtype=object),
            {"long_name": "kind of limit point"},
        ),
    }
    fixed = "fixed_phi_hat" if curve.family == "pressure_volume" else "fixed_p_hat"
    attrs = {
        "title": f"coexist {curve.family} curve",
        "family": curve.family,
        fixed: float(curve.fixed),
        "relative_tolerance": float(curve.rtol),
        "starts_because": curve.starts_because,
        "stopped_because": curve.stopped_because,
    }
    return xr.Dataset(data, coords=coords, attrs=_attrs_safe(attrs))


def ramp_dataset(report, every: int = 1):
    """A :class:`~coexist.simulation.RampReport` as a dataset, from its :meth:`~RampReport.to_dict` (the same
    rows, the same checks): dimensions ``step`` (coordinates ``voltage_kV`` and ``direction``), ``zone``
    (least inflated first) and ``transition``.

    Parameters
    ----------
    report : RampReport
    every : int, optional
        Keep every ``every``-th voltage (and every change of configuration), as :meth:`RampReport.to_dict`.

    Returns
    -------
    xarray.Dataset
        ``pressure_mbar`` (step), ``zone_volume_ml`` and ``pole_stretch`` (step, zone), ``configuration``,
        ``bulged_zones`` (−1 without a state), ``stable`` (step); ``transition_voltage_kV``,
        ``transition_voltage_error_kV``, ``transition_kind``, ``transition_event``, ``transition_from``,
        ``transition_to``, ``transition_direction`` (transition). NaN only where a step has no state.
    """
    xr = _xr()
    d = report.to_dict(every)
    steps = d["steps"]
    n = len(steps)
    N = int(report.scene.zone_count)
    vol = np.full((n, N), np.nan)
    lam = np.full((n, N), np.nan)
    for i, s in enumerate(steps):
        if s["zone_volumes_ml"] is not None:
            vol[i] = s["zone_volumes_ml"]
            lam[i] = s["pole_stretches"]
    pressure = np.array([np.nan if s["pressure_mbar"] is None else s["pressure_mbar"] for s in steps], dtype=float)
    tr = d["transitions"]
    data = {
        "pressure_mbar": ("step", pressure, {"units": "mbar", "long_name": "gauge pressure of the chamber"}),
        "zone_volume_ml": (("step", "zone"), vol, {"units": "ml", "long_name": "volume of each zone"}),
        "pole_stretch": (("step", "zone"), lam, {"units": "1", "long_name": NORMALISED["pole_stretch"]}),
        "configuration": (
            "step",
            np.array([s["configuration"] for s in steps], dtype=object),
            {"long_name": "configuration of the zones ('none': no state)"},
        ),
        "bulged_zones": (
            "step",
            np.array([-1 if s["bulged_zones"] is None else s["bulged_zones"] for s in steps], dtype=np.int64),
            {"units": "1", "long_name": "number of bulged zones (-1: no state)"},
        ),
        "stable": ("step", np.array([bool(s["stable"]) for s in steps]), {"long_name": "the state is stable"}),
        "transition_voltage_kV": (
            "transition",
            np.array([t["voltage_kV"] for t in tr], dtype=float),
            {"units": "kV", "long_name": "voltage of the transition"},
        ),
        "transition_voltage_error_kV": (
            "transition",
            np.array([t["voltage_error_kV"] for t in tr], dtype=float),
            {"units": "kV", "long_name": "measured error of the transition voltage"},
        ),
    }
    for k in ("kind", "event", "from", "to", "direction"):
        data[f"transition_{k}"] = (
            "transition",
            np.array([t[k] for t in tr], dtype=object),
            {"long_name": f"{k} of the transition"},
        )
    coords = {
        "voltage_kV": (
            "step",
            np.array([s["voltage_kV"] for s in steps], dtype=float),
            {"units": "kV", "long_name": "applied voltage"},
        ),
        "direction": ("step", np.array([s["direction"] for s in steps], dtype=object), {"long_name": "ramp direction"}),
        "zone": ("zone", np.arange(1, N + 1), {"long_name": "zone, least inflated first"}),
    }
    attrs = {
        "title": f"coexist ramp of {report.scene.name or report.scene.source}",
        "scene": d["scene"],
        "effects": ", ".join(d["effects"]),
        "relative_tolerance": d["relative_tolerance"],
        "notes": "; ".join(d["notes"]),
    }
    return xr.Dataset(data, coords=coords, attrs=_attrs_safe(attrs))


def sweep_dataset(result):
    """A :class:`~coexist.sweep.SweepResult` as a dataset: one dimension per swept key (named ``section_key_unit``,
    coordinates in the key's unit; ``units`` and ``scene_key`` in the attributes) and ``configuration`` (number
    of bulged zones, 0 homogeneous) for the losses of each configuration.

    Parameters
    ----------
    result : SweepResult

    Returns
    -------
    xarray.Dataset
        The per-point quantities of :mod:`coexist.sweep` (kV; NaN where a point has no such transition, its
        ``status`` and ``reason`` saying why); attributes: the base scene (JSON), the swept keys, the tolerance.
    """
    from . import __version__
    from .sweep import DESCRIPTIONS, FLOAT_FIELDS, INT_FIELDS, STR_FIELDS

    xr = _xr()
    spec = result.spec
    shape = spec.shape
    dims = tuple(ax.dim for ax in spec.axes)
    records = sorted(result.records, key=lambda r: r["index"])
    if [r["index"] for r in records] != list(range(spec.size)):
        from .errors import SolverError

        raise SolverError(f"the sweep has {len(records)} records for {spec.size} points: some are missing")
    data: dict = {}
    for k in FLOAT_FIELDS:
        arr = np.array([np.nan if r[k] is None else r[k] for r in records], dtype=float).reshape(shape)
        units = "1" if k == "closing_pressure_ratio" else "kV"
        data[k] = (dims, arr, {"units": units, "long_name": DESCRIPTIONS.get(k, k.replace("_", " "))})
    for k in INT_FIELDS:
        arr = np.array([r[k] for r in records], dtype=np.int64).reshape(shape)
        data[k] = (dims, arr, {"units": "1", "long_name": DESCRIPTIONS[k]})
    for k in STR_FIELDS:
        arr = np.array([r[k] for r in records], dtype=object).reshape(shape)
        data[k] = (dims, arr, {"long_name": DESCRIPTIONS[k]})
    ks = sorted({int(k) for r in records for key in ("loss_up", "loss_down") for k, _ in r[key]} | {0})
    for key in ("loss_up", "loss_down"):
        arr = np.full((spec.size, len(ks)), np.nan)
        for r in records:
            for k, v in r[key]:
                arr[r["index"], ks.index(int(k))] = v
        data[f"{key}_kV"] = (
            (*dims, "configuration"),
            arr.reshape((*shape, len(ks))),
            {"units": "kV", "long_name": DESCRIPTIONS[f"{key}_kV"]},
        )
    coords: dict = {}
    for ax in spec.axes:
        values = np.array(ax.values, dtype=object if isinstance(ax.values[0], str) else None)
        attrs = {"scene_key": ax.key, "long_name": f"[{ax.section}].{ax.toml_key}", "units": ax.units}
        coords[ax.dim] = (ax.dim, values, _attrs_safe(attrs))
    coords["configuration"] = (
        "configuration",
        np.array(ks, dtype=np.int64),
        {"units": "1", "long_name": "number of bulged zones of the configuration (0: homogeneous)"},
    )
    attrs = {
        "title": f"coexist sweep of {spec.document.get('name') or spec.source}",
        "base_scene": spec.document,
        "base_scene_source": spec.source,
        "swept_keys": ",".join(ax.key for ax in spec.axes),
        "swept_dims": ",".join(dims),
        "relative_tolerance": float(spec.settings.rtol),
        "coexist_version": __version__,
        "missing_values": "NaN where a point has no such transition: status and reason say why",
    }
    return xr.Dataset(data, coords=coords, attrs=_attrs_safe(attrs))


def write_netcdf(dataset, path) -> Path:
    """Write ``dataset`` to a netCDF file with :data:`ENGINE`, through a temporary file beside it renamed onto
    ``path`` (a reader never sees half a file).

    Parameters
    ----------
    dataset : xarray.Dataset
    path : str or pathlib.Path

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    from .files import atomic  # the permissions open() would give; a symbolic link written through

    path = Path(path)
    with atomic(path, suffix=".nc") as tmp:
        dataset.to_netcdf(tmp, engine=ENGINE, invalid_netcdf=False)
    return path


def open_dataset(path):
    """Read a netCDF file written by :func:`write_netcdf` (loaded into memory, the file closed).

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    xarray.Dataset
    """
    xr = _xr()
    with xr.open_dataset(path, engine=ENGINE) as ds:
        return ds.load()
