"""The one atomic writer (freeplayid.atomic.atomic_path): all or nothing, no temporary file left."""

import numpy as np
import pytest

from freeplayid.atomic import TEMP_PREFIX, atomic_path, atomic_write_text
from freeplayid.model import load_system, save_system, two_dof_system


def test_the_block_writes_a_hidden_temporary_beside_the_target_with_its_suffix(tmp_path):
    target = tmp_path / "run.csv.gz"
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(TEMP_PREFIX)
        assert tmp.name.endswith("run.csv.gz")  # np.savetxt gzips it, as the target's name says
        np.savetxt(tmp, np.arange(6.0).reshape(3, 2), delimiter=",")
        assert not target.exists()  # nothing at the target before the block completes
    assert np.array_equal(np.loadtxt(target, delimiter=","), np.arange(6.0).reshape(3, 2))
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv.gz"]


@pytest.mark.parametrize("fault", [RuntimeError, KeyboardInterrupt])
def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, fault):
    target = atomic_write_text(tmp_path / "report.md", "old\n")
    with pytest.raises(fault), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise fault()
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["report.md"]


def test_two_writes_of_one_target_use_two_temporaries(tmp_path):
    with atomic_path(tmp_path / "a.txt") as one, atomic_path(tmp_path / "a.txt") as two:
        assert one != two  # parallel jobs may write the same cache file
        one.write_text("one")
        two.write_text("two")
    assert (tmp_path / "a.txt").read_text() == "one"  # the last rename wins, whole
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_save_system_writes_through_it(tmp_path):
    system = two_dof_system()
    path = save_system(tmp_path / "model", system)
    assert path.name == "model.npz" and [p.name for p in tmp_path.iterdir()] == ["model.npz"]
    assert np.array_equal(load_system(path).K, system.K)
