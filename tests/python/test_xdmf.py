"""The XDMF description (OUT.xdmf) that every native run writes beside its
HDF5 output (docs/output_schema.md, "XDMF description"): a well-formed
document with one grid per frame of /frames, each at its frame's time, whose
every array is a hyperslab of an existing /frames dataset selecting that
frame, for the drum (3D) and the shaken box (2D); current at the end of a
run, at a stop signal, at a checkpoint and when a run stops unstable. Where
ParaView's pvbatch is installed, its XDMF reader reads every frame back."""
import json
import os
import shutil
import signal
import subprocess
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("GRANULAR_BIN", ROOT / "build" / "granular"))
DRUM = ROOT / "scenes" / "drum" / "A.toml"
BOX = ROOT / "scenes" / "box" / "f3.0_big.toml"
# A small drum of a few seconds' run (as in test_resume.py), for the stops.
SMALL_DRUM = ["drum.length=16", "run.rotations=7", "run.snapshot_every=0.5", "run.profile_every=0.02"]

pytestmark = pytest.mark.skipif(not BIN.exists(), reason=f"{BIN} not built")

DTYPES = {"Float": {8: np.float64, 4: np.float32}, "Int": {8: np.int64, 4: np.int32}}


def command(scene, out, sets, *extra):
    c = [str(BIN), "run", str(scene), "-o", str(out), "-q", "--threads", "2"]
    for s in sets:
        c += ["--set", s]
    return c + list(map(str, extra))


def granular(scene, out, sets, *extra, status=0):
    r = subprocess.run(command(scene, out, sets, *extra), capture_output=True, text=True, timeout=600)
    assert r.returncode == status, r.stderr
    return r


@pytest.fixture(scope="module")
def drum_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("drum") / "A.h5"
    granular(DRUM, out, ["run.rotations=0.3", "run.snapshot_every=0.1"])
    return out


@pytest.fixture(scope="module")
def box_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("box") / "f3.0_big.h5"
    granular(BOX, out, ["run.settle=0.05", "run.duration=0.3"])
    return out


def open_h5(path):
    try:
        return h5py.File(path, "r")
    except OSError:  # a file whose writer was killed is still marked open
        return h5py.File(path, "r", swmr=True)


def dims(item):
    return tuple(int(x) for x in item.get("Dimensions").split())


def hyperslabs(root):
    """Every HyperSlab DataItem as (grid index, owner element, start, stride,
    count, result dimensions, HDF5 DataItem)."""
    temporal = root.find("Domain/Grid")
    for f, grid in enumerate(temporal.findall("Grid")):
        for owner in [grid.find("Geometry"), *grid.findall("Attribute")]:
            for slab in owner.findall("DataItem"):
                assert slab.get("ItemType") == "HyperSlab"
                sel, data = slab.findall("DataItem")
                assert sel.get("Format") == "XML" and data.get("Format") == "HDF"
                rank = dims(sel)[1]
                assert dims(sel) == (3, rank)
                values = np.array(sel.text.split(), dtype=np.int64).reshape(3, rank)
                yield f, owner, values[0], values[1], values[2], dims(slab), data


def check_xdmf(h5_path, all_frames=True):
    """The description beside h5_path is well-formed and consistent with the
    file; returns the number of frames it describes. all_frames: it describes
    every frame of the file (else a prefix: a run killed after a checkpoint)."""
    xdmf = h5_path.with_suffix(".xdmf")
    assert xdmf.exists()
    assert not Path(str(xdmf) + ".tmp").exists()
    root = ET.parse(xdmf).getroot()  # raises on a document that is not well-formed
    assert root.tag == "Xdmf"
    temporal = root.find("Domain/Grid")
    assert temporal.get("Name") == "Temporal"
    assert temporal.get("GridType") == "Collection" and temporal.get("CollectionType") == "Temporal"
    grids = temporal.findall("Grid")
    with open_h5(h5_path) as h5:
        times = h5["frames/time"][...]
        dim = int(h5.attrs["dim"])
        n = h5["frames/id"].shape[1]
        if all_frames:
            assert len(grids) == len(times)
        else:
            assert len(grids) <= len(times)
        for f, grid in enumerate(grids):
            assert grid.get("GridType") == "Uniform"
            assert float(grid.find("Time").get("Value")) == times[f]  # exact: written to 17 digits
            topo = grid.find("Topology")
            assert topo.get("TopologyType") == "Polyvertex" and int(topo.get("NumberOfElements")) == n
            assert grid.find("Geometry").get("GeometryType") == ("XYZ" if dim == 3 else "XY")
            names = {a.get("Name"): a.get("AttributeType") for a in grid.findall("Attribute")}
            assert names["diameter"] == names["species"] == "Scalar"
            assert names["velocity"] == "Vector"
            assert names["angular_velocity"] == ("Vector" if dim == 3 else "Scalar")
        seen = set()
        for f, owner, start, stride, count, result, data in hyperslabs(root):
            file, _, dset = data.text.strip().partition(":")
            assert file == h5_path.name  # relative to the XDMF file
            assert (xdmf.parent / file).exists()
            assert dset in h5, f"{dset} is not a dataset of {h5_path.name}"
            ds = h5[dset]
            assert isinstance(ds, h5py.Dataset)
            shape = dims(data)
            assert len(shape) == ds.ndim == len(start)
            if all_frames:
                assert shape == ds.shape, dset
            else:
                assert shape[0] <= ds.shape[0] and shape[1:] == ds.shape[1:], dset
            assert ds.dtype == DTYPES[data.get("NumberType")][int(data.get("Precision"))], dset
            # frame f, the whole row; the selection's shape is the result's
            assert start[0] == f and np.all(start[1:] == 0) and np.all(stride == 1)
            assert count[0] == 1 and tuple(count[1:]) == ds.shape[1:] == result, dset
            assert np.all(start + (count - 1) * stride < np.array(shape))
            seen.add(dset)
        if grids:
            expect = {"position", "diameter", "species", "velocity", "angular_velocity"}
            assert {f"/frames/{k}" for k in expect} <= seen
    return len(grids)


def read_slab(h5, start, stride, count, dset):
    sel = tuple(slice(int(a), int(a) + int(c) * int(s), int(s)) for a, s, c in zip(start, stride, count))
    return h5[dset][sel]


@pytest.mark.parametrize("which", ["drum_run", "box_run"])
def test_description_matches_the_file(which, request):
    out = request.getfixturevalue(which)
    n = check_xdmf(out)
    assert n >= 3  # drum: 0, 0.1, 0.2, 0.3 rotations; box: settled, then its snapshots


@pytest.mark.parametrize("which", ["drum_run", "box_run"])
def test_hyperslab_selects_its_frame(which, request):
    """Read through each hyperslab of one grid as a reader does, with its
    start, stride and count: the values are that frame's, not another's."""
    out = request.getfixturevalue(which)
    root = ET.parse(out.with_suffix(".xdmf")).getroot()
    slabs = list(hyperslabs(root))
    last = max(f for f, *_ in slabs)
    assert last >= 2
    checked = set()
    with open_h5(out) as h5:
        for f, owner, start, stride, count, result, data in slabs:
            if f not in (1, last):
                continue
            dset = data.text.strip().partition(":")[2]
            got = read_slab(h5, start, stride, count, dset).reshape(result)
            want = h5[dset][f]
            np.testing.assert_array_equal(got, want.reshape(result))
            # and not the next frame's (particles move between frames)
            if dset.endswith("/position") or dset.endswith("/velocity"):
                other = h5[dset][f - 1].reshape(result)
                assert not np.array_equal(got, other)
            checked.add((f, owner.get("Name") or "geometry"))
    assert (last, "velocity") in checked and (1, "geometry") in checked


def test_box_description_carries_the_force(box_run):
    root = ET.parse(box_run.with_suffix(".xdmf")).getroot()
    grid = root.find("Domain/Grid/Grid")
    force = [a for a in grid.findall("Attribute") if a.get("Name") == "force"]
    assert len(force) == 1 and force[0].get("AttributeType") == "Vector"


def start_and_wait_for_checkpoint(out, every):
    p = subprocess.Popen(command(DRUM, out, SMALL_DRUM, "--checkpoint-steps", every), stderr=subprocess.PIPE,
                         text=True)
    ckpt = Path(str(out) + ".ckpt")
    deadline = time.monotonic() + 120
    while not ckpt.exists():
        if p.poll() is not None or time.monotonic() > deadline:
            p.kill()
            raise AssertionError(f"the run ended before its first checkpoint: {p.communicate()[1]}")
        time.sleep(0.01)
    return p


def test_description_current_at_stop_signal_and_after_resume(tmp_path):
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(out, 2000)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    if p.returncode == 0:
        pytest.skip("the run finished before the signal arrived")
    assert p.returncode == 130, err
    n = check_xdmf(out)  # stopped: every frame written is described
    assert 1 <= n < 15
    granular(DRUM, out, SMALL_DRUM, "--resume")
    assert check_xdmf(out) == 15  # 0, 0.5, ..., 7 rotations


def test_description_current_at_checkpoint(tmp_path):
    """Killed (SIGKILL) after its one checkpoint half way: the description
    holds the frames the checkpoint recorded, each as in the file."""
    sets = [a for s in SMALL_DRUM for a in ("--set", s)]
    info = json.loads(subprocess.run([str(BIN), "info", str(DRUM), "--json", *sets], capture_output=True, text=True,
                                     check=True).stdout)
    total = info["derived"]["steps_total"]
    out = tmp_path / "drum.h5"
    p = start_and_wait_for_checkpoint(out, total // 2 + 1)  # one checkpoint before the last step
    time.sleep(0.3)
    p.kill()
    p.communicate(timeout=60)
    if p.returncode == 0:
        pytest.skip("the run finished before the kill")
    with h5py.File(str(out) + ".ckpt", "r") as ck:
        recorded = json.loads(ck.attrs["output_rows"])["frames/time"]
    assert 1 <= recorded < 15
    assert check_xdmf(out, all_frames=False) == recorded


def test_description_written_when_a_run_stops_unstable(tmp_path):
    out = tmp_path / "unstable.h5"
    granular(DRUM, out, ["integrator.dt=0.2", "run.rotations=3", "run.snapshot_every=0.01"], status=3)
    assert check_xdmf(out) >= 1


# Run by pvbatch: every frame through ParaView's XDMF reader, saved as .npz.
PV_SCRIPT = """
import sys
import numpy as np
from paraview.simple import XDMFReader
from paraview import servermanager as sm
from vtk.numpy_interface import dataset_adapter as dsa
r = XDMFReader(FileNames=[sys.argv[1]])
r.PointArrayStatus = r.GetProperty("PointArrayInfo")[::2]
r.UpdatePipelineInformation()
out = {"times": np.array(r.TimestepValues, dtype=float)}
for f, t in enumerate(out["times"]):
    r.UpdatePipeline(time=t)
    o = sm.Fetch(r)
    while o.IsA("vtkMultiBlockDataSet"):
        o = o.GetBlock(0)
    d = dsa.WrapDataObject(o)
    out[f"{f}/position"] = np.asarray(d.Points)
    out[f"{f}/cells"] = np.array(o.GetNumberOfCells())
    for n in d.PointData.keys():
        out[f"{f}/{n}"] = np.asarray(d.PointData[n])
np.savez(sys.argv[2], **out)
"""


@pytest.mark.skipif(shutil.which("pvbatch") is None, reason="ParaView (pvbatch) not installed")
@pytest.mark.parametrize("which", ["drum_run", "box_run"])
def test_paraview_reads_every_frame(which, request, tmp_path):
    out = request.getfixturevalue(which)
    script = tmp_path / "read.py"
    script.write_text(PV_SCRIPT)
    got = tmp_path / "got.npz"
    r = subprocess.run(["pvbatch", str(script), str(out.with_suffix(".xdmf")), str(got)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0 and got.exists(), r.stdout + r.stderr
    pv = np.load(got)
    with open_h5(out) as h5:
        times = h5["frames/time"][...]
        dim = int(h5.attrs["dim"])
        n = h5["frames/id"].shape[1]
        np.testing.assert_array_equal(pv["times"], times)
        for f in range(len(times)):
            assert int(pv[f"{f}/cells"]) == n
            pos = pv[f"{f}/position"]
            np.testing.assert_array_equal(pos[:, :dim], h5["frames/position"][f])
            assert dim == 3 or np.all(pos[:, 2] == 0)
            names = [k.split("/", 1)[1] for k in pv.files if k.startswith(f"{f}/")]
            assert {"diameter", "species", "id", "velocity", "angular_velocity"} <= set(names)
            for name in set(names) - {"position", "cells"}:
                want = h5["frames/" + name][f]
                a = pv[f"{f}/{name}"]
                if a.ndim == 2 and a.shape[1] == 3 and want.shape[-1] == 2:  # 2D vectors come in with z = 0
                    assert np.all(a[:, 2] == 0)
                    a = a[:, :2]
                np.testing.assert_array_equal(a.reshape(want.shape), want, err_msg=f"frame {f}: {name}")
