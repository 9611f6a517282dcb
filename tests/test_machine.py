"""Cores a process may use (src/tissuempm/machine.py): the affinity mask and the cgroup quota, not the host's
count, so a container given 2 of 64 cores starts 2 solver threads, not 64."""

import os

import pytest

from tissuempm import machine


def _v1(root, quota: str, period: str = "100000"):
    (root / "cpu").mkdir()
    (root / "cpu" / "cpu.cfs_quota_us").write_text(quota + "\n")
    (root / "cpu" / "cpu.cfs_period_us").write_text(period + "\n")
    return root


@pytest.mark.parametrize("text, cores", [("200000 100000", 2.0), ("50000 100000", 0.5), ("max 100000", None)])
def test_cgroup_v2_quota(tmp_path, text, cores):
    (tmp_path / "cpu.max").write_text(text + "\n")
    assert machine.cgroup_quota(tmp_path) == cores


@pytest.mark.parametrize("quota, cores", [("300000", 3.0), ("-1", None)])
def test_cgroup_v1_quota(tmp_path, quota, cores):
    assert machine.cgroup_quota(_v1(tmp_path, quota)) == cores


@pytest.mark.parametrize("text", ["", "lots 100000", "100000 0"])
def test_malformed_or_missing_quota_means_none(tmp_path, text):
    assert machine.cgroup_quota(tmp_path) is None  # no file at all
    (tmp_path / "cpu.max").write_text(text)
    assert machine.cgroup_quota(tmp_path) is None


def test_usable_cores_is_the_smallest_limit(monkeypatch):
    affinity = len(os.sched_getaffinity(0))
    monkeypatch.setattr(machine, "cgroup_quota", lambda: None)
    assert machine.usable_cores() == affinity
    monkeypatch.setattr(machine, "cgroup_quota", lambda: 0.5)  # half a core: one thread, never zero
    assert machine.usable_cores() == 1
    monkeypatch.setattr(machine, "cgroup_quota", lambda: affinity + 7.0)  # a quota above the mask: the mask
    assert machine.usable_cores() == affinity


def test_solver_threads_follow_the_usable_cores(monkeypatch):
    from tissuempm.mpm.config import SolverConfig

    monkeypatch.setattr(machine, "cgroup_quota", lambda: 1.0)
    assert SolverConfig().n_threads == 1
    assert SolverConfig(threads=3).n_threads == 3
