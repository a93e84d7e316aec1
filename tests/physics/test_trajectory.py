"""The trajectory format: round trip through netCDF and a clear error for every malformation."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from physics import TrajectoryFormatError, load_trajectory, make_trajectory, save_trajectory, validate_trajectory


def _small(T=5):
    t = np.arange(T) * 0.01
    nodes = np.random.default_rng(0).normal(size=(T, 12, 3))
    return make_trajectory(t, nodes, np.ones((T, 24)), rest_length=np.ones((T, 24)))


def test_round_trip_netcdf(tmp_path, flop_data):
    path = save_trajectory(flop_data, tmp_path / "sub" / "traj.nc")
    back = load_trajectory(path)
    xr.testing.assert_identical(back, flop_data)
    assert list(back.cable.values[:2]) == ["c00_04", "c00_05"]
    assert back.nodes.attrs["units"] == "m"
    assert back.attrs["format"] == "tensegrid-trajectory-1"


def test_missing_samples_are_allowed_as_nan():
    ds = _small()
    ds["nodes"][2, 3, 0] = np.nan
    validate_trajectory(ds)


def _bad(mutate):
    ds = _small()
    return mutate(ds)


@pytest.mark.parametrize("mutate, match", [
    (lambda ds: ds.drop_vars("controls"), "missing variable 'controls'"),
    (lambda ds: ds.isel(node=slice(0, 10)), "'node' must have 12 entries"),
    (lambda ds: ds.isel(cable=slice(0, 20)), "'cable' must have 24 entries"),
    (lambda ds: ds.assign_coords(time=[0.0, 0.01, 0.005, 0.03, 0.04]), "must increase strictly; it does not at index 2"),
    (lambda ds: ds.assign_coords(time=[0.0, 0.01, 0.02, 0.04, 0.05]), "uniformly sampled"),
    (lambda ds: ds.isel(time=slice(0, 1)), "at least 2 time samples"),
    (lambda ds: ds.assign(nodes=ds.nodes.assign_attrs(units="mm")), r"metres \(units='m'\), got units='mm'"),
    (lambda ds: ds.assign(nodes=ds.nodes * np.inf), "infinite"),
    (lambda ds: ds.assign(nodes=ds.nodes * np.nan), "no finite sample"),
    (lambda ds: ds.assign(controls=ds.controls.rename(cable="c")), r"must have dims \(time, cable\)"),
    (lambda ds: ds.assign_coords(end_a=("cable", np.roll(ds.end_a.values, 1))), "cable layout"),
    (lambda ds: ds.to_array(), "expected an xarray.Dataset"),
])
def test_every_malformation_is_named(mutate, match):
    with pytest.raises(TrajectoryFormatError, match=match):
        validate_trajectory(_bad(mutate))


def test_loading_bad_files(tmp_path):
    with pytest.raises(TrajectoryFormatError, match="does not exist"):
        load_trajectory(tmp_path / "nope.nc")
    junk = tmp_path / "junk.nc"
    junk.write_text("not a netcdf file")
    with pytest.raises(TrajectoryFormatError, match="is not a netCDF trajectory; convert it first: tensegrid convert"):
        load_trajectory(junk)
    truncated = tmp_path / "truncated.nc"
    truncated.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00" * 8)         # a netCDF-4 signature, then nothing
    with pytest.raises(TrajectoryFormatError, match="Cannot read"):
        load_trajectory(truncated)
    bad = _small().drop_vars("nodes")
    bad.to_netcdf(tmp_path / "bad.nc")
    with pytest.raises(TrajectoryFormatError, match=r"bad.nc: missing variable 'nodes'"):
        load_trajectory(tmp_path / "bad.nc")
