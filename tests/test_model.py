"""Tests of crumple.model: the paper's stiffness definitions, the continuum limit of the
factories, and validation of every parameter."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from crumple.model import Plasticity, Wire

# --------------------------------------------------------------------------------------------
# Defaults and derived quantities
# --------------------------------------------------------------------------------------------


def test_defaults_are_the_papers_table_1():
    w = Wire(k_b=5, k_s=5e5)
    assert w.n_segments == 100
    assert w.n_nodes == 101
    assert w.length == 1.0
    assert w.rest_length == pytest.approx(0.01)
    assert w.hard_core == 1e-5
    assert w.plasticity is None
    assert w.trap_center == (0.0, 0.0)
    assert w.confinement in ("per-length", "per-node")


def test_continuum_stiffnesses_are_discrete_times_segment_length():
    w = Wire(k_b=5, k_s=5e5, n_segments=50, length=2.0)
    assert w.rest_length == pytest.approx(0.04)
    assert w.bending_stiffness == pytest.approx(5 * 0.04)
    assert w.stretching_stiffness == pytest.approx(5e5 * 0.04)


def test_frozen_and_keyword_only():
    w = Wire(k_b=5, k_s=5e5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        w.k_b = 1.0
    with pytest.raises(TypeError):
        Wire(5, 5e5)
    with pytest.raises(TypeError):
        Wire(k_b=5, k_s=5e5, kb=3)  # a misspelled name is not swallowed


# --------------------------------------------------------------------------------------------
# Factories: the paper's k_b = Y I / (L0/N), k_s = Y A / (L0/N)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [10, 100, 1000])
@pytest.mark.parametrize(("young", "radius", "length"), [(1e9, 1e-3, 1.0), (2.5e6, 4e-3, 3.0)])
def test_from_material_matches_the_papers_definitions(young, radius, length, n):
    w = Wire.from_material(young=young, radius=radius, n_segments=n, length=length)
    inertia = math.pi * radius**4 / 4
    area = math.pi * radius**2
    seg = length / n
    assert w.k_b == pytest.approx(young * inertia / seg, rel=1e-12)
    assert w.k_s == pytest.approx(young * area / seg, rel=1e-12)
    assert w.k_s / w.k_b == pytest.approx(4 / radius**2, rel=1e-12)  # circular section
    assert w.n_segments == n and w.length == length


def test_from_material_hand_value():
    # Y = 1e9, r = 1e-3, N = 100, L0 = 1: k_b = 1e9 * pi 1e-12 / 4 / 0.01 = 0.0785398...
    w = Wire.from_material(young=1e9, radius=1e-3, n_segments=100)
    assert w.k_b == pytest.approx(0.07853981633974483, rel=1e-14)
    assert w.k_s == pytest.approx(314159.2653589793, rel=1e-14)


def test_from_continuum_scales_with_n_at_fixed_continuum_stiffness():
    b, s = 0.05, 5000.0
    w1 = Wire.from_continuum(bending=b, stretching=s, n_segments=200)
    w2 = Wire.from_continuum(bending=b, stretching=s, n_segments=400)
    assert w1.k_b == pytest.approx(10.0)
    assert w1.k_s == pytest.approx(1e6)
    assert w2.k_b == pytest.approx(2 * w1.k_b, rel=1e-14)
    assert w2.k_s == pytest.approx(2 * w1.k_s, rel=1e-14)
    for w in (w1, w2):
        assert w.bending_stiffness == pytest.approx(b, rel=1e-14)
        assert w.stretching_stiffness == pytest.approx(s, rel=1e-14)


def test_from_continuum_with_length_and_extra_parameters():
    p = Plasticity(s=0.2, theta_p=0.3)
    w = Wire.from_continuum(
        bending=0.1,
        stretching=100.0,
        n_segments=40,
        length=2.0,
        plasticity=p,
        confinement="per-node",
    )
    assert w.k_b == pytest.approx(0.1 / (2.0 / 40))
    assert w.k_s == pytest.approx(100.0 / (2.0 / 40))
    assert w.plasticity == p and w.confinement == "per-node"


def test_round_trip_through_dict():
    w = Wire(
        k_b=2,
        k_s=3e4,
        n_segments=30,
        confinement="per-node",
        plasticity=Plasticity(s=0.4, theta_p=0.2),
        trap_center=(0.5, -1),
    )
    assert Wire.from_dict(w.to_dict()) == w
    assert Wire.from_dict(Wire(k_b=1, k_s=1e4).to_dict()) == Wire(k_b=1, k_s=1e4)
    with pytest.raises(ValueError, match="kb"):
        Wire.from_dict({"kb": 1, "k_s": 1e4})


def test_replace_validates_again():
    w = Wire(k_b=5, k_s=5e5)
    assert w.replace(k_b=2).k_b == 2.0
    with pytest.raises(ValueError, match="k_b"):
        w.replace(k_b=-2)


def test_numpy_scalars_are_accepted():
    """Parameters read back from HDF5 attributes or taken from numpy arrays are numpy scalars."""
    w = Wire(k_b=np.float64(5), k_s=np.float32(5e5), n_segments=np.int64(50))
    assert w == Wire(k_b=5, k_s=5e5, n_segments=50)
    assert type(w.n_segments) is int
    w2 = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=np.int64(200))
    assert w2.k_b == pytest.approx(10.0)


def test_ints_and_floats_are_the_same_parameters():
    assert Wire(k_b=5, k_s=500000) == Wire(k_b=5.0, k_s=5e5)
    assert Wire(k_b=5, k_s=5e5, n_segments=20.0).n_segments == 20
    assert isinstance(Wire(k_b=5, k_s=5e5, n_segments=20.0).n_segments, int)


# --------------------------------------------------------------------------------------------
# Validation: a ValueError that names the parameter and the value
# --------------------------------------------------------------------------------------------

GOOD = {"k_b": 5.0, "k_s": 5e5}

BAD_WIRE = [
    ("k_b", 0),
    ("k_b", -1.0),
    ("k_b", math.nan),
    ("k_b", math.inf),
    ("k_b", "stiff"),
    ("k_s", 0.0),
    ("k_s", -5e5),
    ("k_s", math.nan),
    ("k_s", -math.inf),
    ("n_segments", 2),
    ("n_segments", 0),
    ("n_segments", -10),
    ("n_segments", 2.5),
    ("n_segments", math.nan),
    ("n_segments", math.inf),
    ("n_segments", True),
    ("n_segments", "100"),
    ("length", 0.0),
    ("length", math.nan),
    ("hard_core", 0.0),
    ("hard_core", -1e-5),
    ("hard_core", math.inf),
    ("hard_core_energy", 0.0),
    ("hard_core_energy", math.nan),
    ("confinement", "per-monomer"),
    ("trap_center", (0.0, math.nan)),
    ("trap_center", (math.inf, 0.0)),
    ("trap_center", 3.0),
    ("plasticity", {"s": 0.5, "theta_p": 0.1}),
]


@pytest.mark.parametrize(("name", "value"), BAD_WIRE, ids=[f"{n}={v!r}" for n, v in BAD_WIRE])
def test_wire_rejects_bad_parameter(name, value):
    with pytest.raises(ValueError) as info:
        Wire(**{**GOOD, name: value})
    msg = str(info.value)
    assert name in msg
    assert repr(value) in msg or str(value) in msg


BAD_PLASTICITY = [
    ("s", -0.1, 0.3),
    ("s", 1.0000001, 0.3),
    ("s", math.nan, 0.3),
    ("s", math.inf, 0.3),
    ("theta_p", 0.5, 0.0),
    ("theta_p", 0.5, -0.2),
    ("theta_p", 0.5, math.nan),
    ("theta_p", 0.5, math.inf),
]


@pytest.mark.parametrize(("name", "s", "theta_p"), BAD_PLASTICITY)
def test_plasticity_rejects_bad_parameter(name, s, theta_p):
    with pytest.raises(ValueError) as info:
        Plasticity(s=s, theta_p=theta_p)
    msg = str(info.value)
    assert name in msg
    bad = s if name == "s" else theta_p
    assert repr(bad) in msg or str(bad) in msg


@pytest.mark.parametrize("s", [0.0, 0.05, 1.0])
def test_plasticity_accepts_the_closed_interval(s):
    assert Plasticity(s=s, theta_p=0.1).s == s


def test_hard_core_must_be_below_the_segment_length():
    with pytest.raises(ValueError, match="hard_core"):
        Wire(k_b=5, k_s=5e5, n_segments=100, hard_core=0.02)
    assert Wire(k_b=5, k_s=5e5, n_segments=100, hard_core=0.005).hard_core == 0.005


BAD_FACTORY = [
    ("young", {"young": -1.0, "radius": 1e-3}),
    ("young", {"young": math.nan, "radius": 1e-3}),
    ("radius", {"young": 1e9, "radius": 0.0}),
    ("radius", {"young": 1e9, "radius": math.inf}),
    ("n_segments", {"young": 1e9, "radius": 1e-3, "n_segments": 2}),
]


@pytest.mark.parametrize(("name", "kwargs"), BAD_FACTORY)
def test_from_material_rejects_bad_parameter(name, kwargs):
    with pytest.raises(ValueError, match=name):
        Wire.from_material(**kwargs)


@pytest.mark.parametrize(
    ("name", "kwargs"),
    [
        ("bending", {"bending": 0.0, "stretching": 1.0}),
        ("bending", {"bending": math.nan, "stretching": 1.0}),
        ("stretching", {"bending": 1.0, "stretching": -1.0}),
        ("stretching", {"bending": 1.0, "stretching": math.inf}),
        ("n_segments", {"bending": 1.0, "stretching": 1.0, "n_segments": 1}),
        ("length", {"bending": 1.0, "stretching": 1.0, "length": -1.0}),
    ],
)
def test_from_continuum_rejects_bad_parameter(name, kwargs):
    with pytest.raises(ValueError, match=name):
        Wire.from_continuum(**kwargs)
