"""Drive trains in MuJoCo: N flywheels (2..8) on coaxial hinges, a joint law between neighbours.

A chain model file (``models/pump_train.xml``) has

* hinges ``phi1 .. phiN`` on one axis, bodies not inertially coupled;
* motors ``drive<i>`` on hinge ``phi<i>`` (one or more, any flywheels), each with an
  ``actuatorfrc`` sensor ``drive<i>_torque`` (the torque a bench records);
* ``jointpos`` sensors ``phi<i>`` (an angle without a sensor is not measured: the record holds
  None there, and the identifier says what that leaves unidentifiable); optional ``jointvel``
  sensors ``rate<i>``;
* per joint j (between flywheels j and j+1) its law's fields with the prefix
  ``jointrig_joint<j>_`` (``jointrig_joint2_k_Nm_per_rad``: every field a two-flywheel model
  knows, read by the same term classes, :data:`vocab.law.TERM_CLASSES`), and
  ``jointrig_bearing<i>_damping_Nms_per_rad`` for a flywheel's drag to ground;
* optionally ``jointrig_drive_delay_s``: every drive acts this long after it is recorded (the
  rig turns each periodic drive by its delay; the record holds the drive as commanded).

The passive callback applies every joint's torque (``-M_j`` on flywheel j, ``+M_j`` on j+1),
the bearings and the drives, evaluated at continuous time as in :mod:`rig.simulate`, except
the jump of a law's dry friction: a joint's is held by MuJoCo's friction constraint on the
fixed tendon ``phi<j> - phi<j+1>`` (``jointrig_twist<j>``, added on loading), a body's to ground
by its dof's ``frictionloss``, so a joint or body that sticks stays stuck. The callback is
installed only around a run by :func:`rig.callback.passive_callback`. Stateful terms (Jenkins,
Iwan) keep one state list per joint, committed after every step.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import math
import os
import re
import time as _time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Optional, Sequence, Union

import mujoco
import numpy as np

from jointrig.vocab.law import FieldError, JointLaw, law_terms_from_fields
from jointrig.vocab.params import DRIVE_DELAY, HINGE, SLIDE, Coordinate
from jointrig.identify.chain import ChainPlant, ChainRecord

from .model import JOINT_FIELD as _JOINT_FIELD
from .model import (PREFIX, TWIST_SOLIMP, TWIST_SOLREF, TWIST_TENDON, RigModelError, compile_model, is_chain_model,
                    with_twist_tendons)
from .native_callback import NativeChain, choose_native, session_active
from .simulate import (SettleInfo, SimulationConfig, SimulationError, _activated, _Jump, _settle, dry_friction_split,
                       passive_callback, set_inertias)

__all__ = ["ChainRig", "load_chain", "is_chain_model", "simulate_chain", "chain_callback", "MAX_FLYWHEELS",
           "chain_model_xml"]

MAX_FLYWHEELS = 8
_GROUND_FIELD = re.compile(r"ground(\d+)_(.+)")
#: MuJoCo's joint of each coordinate, and a body's inertial element for its inertia (a hinge's, kg
#: m^2 about the axis) or mass (a slide's, kg)
_MJ_JOINT = {HINGE: mujoco.mjtJoint.mjJNT_HINGE, SLIDE: mujoco.mjtJoint.mjJNT_SLIDE}
_INERTIAL = {
    HINGE: lambda J: f'<inertial pos="0 0 0" mass="1" diaginertia="{0.5 * J * (1 + 1e-9)!r} {0.5 * J * (1 + 1e-9)!r} {J!r}"/>',
    SLIDE: lambda m: f'<inertial pos="0 0 0" mass="{m!r}" diaginertia="1 1 1"/>',
}


@dataclass(frozen=True, eq=False)
class ChainRig:
    """A compiled chain model.

    Attributes:
      path: the MJCF file; model: the compiled ``MjModel``; plant: joint laws and bearings.
      inertias_kgm2: each flywheel's inertia about the axis (from the compiled mass matrix).
      qpos_adr, dof_adr: addresses of phi1..phiN.
      drives: ``(flywheel number, actuator id, sensor address)`` of every drive.
      angle_adr, rate_adr: per flywheel, the sensor address or None (not measured).
      digest: SHA-256 of the file.
      twist_tendons: per joint, the id of the fixed tendon ``phi<j> - phi<j+1>`` the rig adds
        (``jointrig_twist<j>``): its ``frictionloss`` holds the joint's dry friction.
    """

    path: Path
    model: mujoco.MjModel
    plant: ChainPlant
    inertias_kgm2: tuple
    qpos_adr: tuple
    dof_adr: tuple
    drives: tuple
    angle_adr: tuple
    rate_adr: tuple
    digest: str
    #: how the bodies move: on hinges (angles in rad, torques in N m, inertias in kg m^2) or slides (m, N, kg)
    kind: Coordinate = HINGE
    twist_tendons: tuple = ()

    @property
    def n_flywheels(self) -> int:
        return len(self.inertias_kgm2)

    @property
    def driven(self) -> tuple[int, ...]:
        return tuple(i for i, _, _ in self.drives)

    def with_plant(self, plant: ChainPlant) -> "ChainRig":
        if plant.n_flywheels != self.n_flywheels:
            raise ValueError(f"{self.path}: a plant of {plant.n_flywheels} flywheels for a chain of {self.n_flywheels}")
        return replace(self, plant=plant)


def _law(fields: dict, where: str, field_prefix: str, src: str, kind: Coordinate) -> Optional[JointLaw]:
    """A law from its fields (the project's hinge names; ``field_prefix`` for messages)."""
    try:
        pairs = law_terms_from_fields(fields)
    except FieldError as err:
        raise RigModelError(f"{src}: {where}: {str(err).replace(PREFIX, PREFIX + field_prefix)}") from None
    known = {f for t, _ in pairs for f in type(t).MJCF_FIELDS}
    unknown = sorted(set(fields) - known)
    if unknown:
        raise RigModelError(f"{src}: {where}: unknown law field(s) {[PREFIX + field_prefix + kind.name(u) for u in unknown]}")
    if not pairs:
        return None
    return JointLaw(tuple(t for t, _ in pairs), tuple(v for _, v in pairs))


def _plant(model: mujoco.MjModel, N: int, src: str, kind: Coordinate) -> ChainPlant:
    per_joint: dict[int, dict] = {j: {} for j in range(1, N)}
    per_ground: dict[int, dict] = {i: {} for i in range(1, N + 1)}
    bearings = [0.0] * N
    delay = 0.0
    drag = kind.drag
    drag_unit = kind.name("bearing1_damping_Nms_per_rad").rsplit("_damping_", 1)[1]
    for i in range(model.nnumeric):
        name = model.numeric(i).name
        if not name.startswith(PREFIX):
            continue
        rest = name[len(PREFIX):]
        data = np.array(model.numeric(i).data, dtype=float)
        m = _JOINT_FIELD.fullmatch(rest)
        g = _GROUND_FIELD.fullmatch(rest)
        b = re.fullmatch(rf"{drag}(\d+)_damping_{drag_unit}", rest)
        if m and 1 <= int(m.group(1)) < N:  # a slide's fields are in N and m
            per_joint[int(m.group(1))][kind.project_name(m.group(2))] = data
        elif g and 1 <= int(g.group(1)) <= N:
            per_ground[int(g.group(1))][kind.project_name(g.group(2))] = data
        elif b and 1 <= int(b.group(1)) <= N:
            if data.size != 1 or not np.isfinite(data[0]) or data[0] < 0:
                raise RigModelError(f"{src}: {name} must hold one finite number >= 0, got {data}")
            bearings[int(b.group(1)) - 1] = float(data[0])
        elif rest == DRIVE_DELAY:
            if data.size != 1 or not np.isfinite(data[0]):
                raise RigModelError(f"{src}: {name} must hold one finite number (s), got {data}")
            delay = float(data[0])
        else:
            raise RigModelError(f"{src}: unknown field {name}; a chain of {N} bodies on {kind}s takes "
                                + (f"{PREFIX}joint<j>_<law field> (j = 1..{N - 1}), " if N > 1 else "")
                                + f"{PREFIX}ground<i>_<law field> and {PREFIX}{drag}<i>_damping_{drag_unit} (i = 1..{N}), "
                                f"and {PREFIX}{DRIVE_DELAY}")
    laws = []
    for j in range(1, N):
        law = _law(per_joint[j], f"joint {j}", f"joint{j}_", src, kind)
        if law is None:
            raise RigModelError(f"{src}: joint {j} (bodies {j}-{j + 1}) has no law: add fields "
                                f"{PREFIX}joint{j}_{kind.name('k_Nm_per_rad')} etc.")
        laws.append(law)
    grounds = tuple(_law(per_ground[i], f"body {i}'s law to ground", f"ground{i}_", src, kind)
                    for i in range(1, N + 1))
    return ChainPlant(tuple(laws), tuple(bearings), grounds, delay)


def load_chain(path: Union[str, os.PathLike]) -> ChainRig:
    """Compile and check a chain model (see the module docstring for what it must hold).

    Raises:
      RigModelError: missing file, MJCF that does not compile, hinges not numbered 1..N or not
        coaxial, N outside 2..8, a drive without its torque sensor, a joint without a law;
        the message names the file and the item.
    """
    path, text, model = compile_model(path)
    src = str(path)
    J_ = mujoco.mjtObj.mjOBJ_JOINT
    kind = SLIDE if mujoco.mj_name2id(model, J_, SLIDE.position + "1") >= 0 else HINGE
    coord = kind.position
    ids = []
    while True:
        jid = mujoco.mj_name2id(model, J_, f"{coord}{len(ids) + 1}")
        if jid < 0:
            break
        ids.append(jid)
    N = len(ids)
    if not 1 <= N <= MAX_FLYWHEELS:
        raise RigModelError(f"{src}: a chain has hinges phi1..phiN (or slides x1..xN) with N from 1 to "
                            f"{MAX_FLYWHEELS}; found {N}")
    if model.njnt != N:
        extra = [mujoco.mj_id2name(model, J_, j) for j in range(model.njnt) if j not in ids]
        raise RigModelError(f"{src}: joints {extra} are not part of the chain {coord}1..{coord}{N}")
    want = _MJ_JOINT[kind]
    for k, jid in enumerate(ids, start=1):
        if model.jnt_type[jid] != want:
            raise RigModelError(f"{src}: joint '{coord}{k}' must be a {kind} (bodies on one line are all "
                                f"{kind}s {coord}1..{coord}N)")
        if not np.allclose(model.jnt_axis[jid], model.jnt_axis[ids[0]]):
            raise RigModelError(f"{src}: joint '{coord}{k}' must share {coord}1's axis (bodies on one line)")
    S_ = mujoco.mjtObj.mjOBJ_SENSOR

    def sensor(name: str, kind) -> Optional[int]:
        sid = mujoco.mj_name2id(model, S_, name)
        if sid < 0:
            return None
        if model.sensor_type[sid] != kind:
            raise RigModelError(f"{src}: sensor '{name}' must be a {kind.name[7:].lower()} sensor")
        return int(model.sensor_adr[sid])

    drives = []
    for a in range(model.nu):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
        m = re.fullmatch(r"drive(\d+)", name or "")
        if not m or not 1 <= int(m.group(1)) <= N:
            raise RigModelError(f"{src}: actuator '{name}': a chain's motors are named drive<i> (i = 1..{N}) "
                                f"and drive joint {coord}<i>")
        i = int(m.group(1))
        if model.actuator_trnid[a, 0] != ids[i - 1]:
            raise RigModelError(f"{src}: actuator '{name}' must drive joint '{coord}{i}'")
        if model.actuator_ctrllimited[a]:
            raise RigModelError(f"{src}: actuator '{name}' must not be ctrllimited (the torque would be clipped)")
        adr = sensor(f"{name}_torque", mujoco.mjtSensor.mjSENS_ACTUATORFRC)
        if adr is None:
            raise RigModelError(f"{src}: actuator '{name}' needs an actuatorfrc sensor '{name}_torque' "
                                f"(the recorded drive torque)")
        drives.append((i, a, adr))
    if not drives:
        raise RigModelError(f"{src}: no drive: add <motor name=\"drive1\" joint=\"{coord}1\"/> and its sensor")
    angle_adr = tuple(sensor(f"{coord}{i}", mujoco.mjtSensor.mjSENS_JOINTPOS) for i in range(1, N + 1))
    rate_adr = tuple(sensor(f"rate{i}", mujoco.mjtSensor.mjSENS_JOINTVEL) for i in range(1, N + 1))
    plant = _plant(model, N, src, kind)
    # A joint's dry friction is held by MuJoCo's constraint on its twist, as the two-flywheel
    # rig's is: the fixed tendon phi<j> - phi<j+1>, its frictionloss set per run.
    names = [f"{TWIST_TENDON}{j}" for j in range(1, N)]
    if names:
        model = with_twist_tendons(path, src, [(t, f"{coord}{j}", f"{coord}{j + 1}") for j, t in enumerate(names, 1)])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mass = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass)
    dofs = tuple(int(model.jnt_dofadr[j]) for j in ids)
    off = mass[np.ix_(dofs, dofs)] - np.diag(np.diag(mass[np.ix_(dofs, dofs)]))
    if np.max(np.abs(off)) > 1e-12 * np.max(np.diag(mass)):
        raise RigModelError(f"{src}: flywheels must not be inertially coupled (each body a child of the world)")
    return ChainRig(path=path, model=model, plant=plant,
                    inertias_kgm2=tuple(float(mass[d, d]) for d in dofs),
                    qpos_adr=tuple(int(model.jnt_qposadr[j]) for j in ids), dof_adr=dofs,
                    drives=tuple(sorted(drives)), angle_adr=angle_adr, rate_adr=rate_adr,
                    digest=hashlib.sha256(text).hexdigest(), kind=kind,
                    twist_tendons=tuple(int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TENDON, t)) for t in names))


def _compiled(plant: ChainPlant, inertias_kgm2: Sequence[float], driven: Sequence[int], name: str,
              kind: str = HINGE, source=None) -> ChainRig:
    """The chain rig of ``plant`` (:func:`chain_model_xml`, compiled from a temporary file),
    named ``name``; ``source``: the model file it was made from (its path and digest are kept,
    and a law the chain's fields cannot write is refused naming it)."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="jointrig-chain-") as tmp:
        path = Path(tmp) / name
        try:
            path.write_text(chain_model_xml(plant, inertias_kgm2, driven, kind=kind), encoding="utf-8")
        except ValueError as err:  # a law the chain's fields cannot write
            if source is None:
                raise
            raise RigModelError(f"{source.path}: {err}") from None
        out = load_chain(path)
    return replace(out, path=Path(name)) if source is None else replace(out, path=source.path, digest=source.digest)


def rig_of_bodies(n_bodies: int, driven: Sequence[int], kind: str = HINGE) -> ChainRig:
    """The rig of a measured file's bodies and drives, without the user's model: the paper's law
    at every joint (a single body: its drag to ground) and unit inertias, hinges or slides; a
    diagnosis replaces the plant and the inertias by each fit's. Named ``train.xml``."""
    from jointrig.identify.chain import plant_of_values
    from jointrig.identify.chain_diagnose import nominal_spec

    spec = nominal_spec(n_bodies)
    return _compiled(plant_of_values({n: 0.0 for n in spec.names}, spec), [1.0] * n_bodies, driven, "train.xml", kind)


def chain_of_two_flywheels(rig, driven: Sequence[int]) -> ChainRig:
    """A two-flywheel model (:func:`rig.model.load_rig`'s) as the train of its two bodies, the one
    model of every bench: its law at joint 1, its bearings, inertias and drive lag, with motors on
    ``driven`` (the bodies the data drive); named by its own file and digest."""
    p = rig.plant
    plant = ChainPlant((p.law,), (p.bearing1_damping_Nms_per_rad, p.bearing2_damping_Nms_per_rad), (), p.drive_delay_s)
    return _compiled(plant, (rig.J1_kgm2, rig.J2_kgm2), driven, rig.path.name, source=rig)


def load_model(path: Union[str, os.PathLike], driven: Sequence[int] = (1,)) -> ChainRig:
    """Any model file as the line of its bodies, the one rig of every bench: a chain model as
    :func:`load_chain` reads it; a two-flywheel model (:func:`rig.model.load_rig`'s) as the train of
    its two bodies with motors on ``driven`` (the bodies the data drive).

    Raises :class:`rig.model.RigModelError` naming the file and the item."""
    from .model import load_rig

    return load_chain(path) if is_chain_model(path) else chain_of_two_flywheels(load_rig(path), driven)


def torque_share(rig: ChainRig, torque_on: str = "flywheel1") -> float:
    """The share of two flywheels' drive that twists their joint: the undriven flywheel's inertia
    over both (``torque_on`` says which is driven)."""
    J1, J2 = rig.inertias_kgm2
    return (J1 if torque_on == "flywheel2" else J2) / (J1 + J2)


def relative_chain(rig: ChainRig) -> ChainRig:
    """Two flywheels' model as its relative-angle form (:mod:`measured.runs`): one body of inertia
    ``J1 J2/(J1 + J2)`` tied to the frame by the joint's law, driven on body 1 (by
    :func:`torque_share` of the drive); exact without bearing drag, which the relative angle alone
    cannot hold."""
    p = rig.plant
    if rig.n_flywheels != 2:
        raise RigModelError(f"{rig.path}: {rig.n_flywheels} bodies; the relative angle alone ('phi') is the twist of "
                            f"two flywheels' joint: give each body's angle (phi1..phi{rig.n_flywheels})")
    if any(p.bearings_Nms_per_rad) or any(g is not None for g in p.grounds):
        raise RigModelError(f"{rig.path}: bearing drag to ground (jointrig_bearing*): the relative angle alone ('phi') "
                            f"moves as one body only without it; give both angles (phi1, phi2) to diagnose this model")
    J1, J2 = rig.inertias_kgm2
    return _compiled(ChainPlant((), (0.0,), (p.laws[0],), p.drive_delay_s), (J1 * J2 / (J1 + J2),), (1,),
                     rig.path.name, source=rig)


def two_flywheels_of_relative(plant: ChainPlant, J_kgm2: float, share: float, torque_on: str) -> tuple:
    """The relative-angle form's one body (its law to ground, inertia ``J1 J2/(J1 + J2)``) as the
    two flywheels it stands for, the inverse of :func:`relative_chain`:
    ``(plant, (J1, J2), driven)``, the law at joint 1, the undriven flywheel's inertia
    ``J/(1 - share)`` and the driven one's ``J/share`` (pure)."""
    driven_J, other_J = J_kgm2 / share, J_kgm2 / (1.0 - share)
    two = ChainPlant((plant.grounds[0],), (0.0, 0.0), (), plant.drive_delay_s)
    if torque_on == "flywheel2":
        return two, (other_J, driven_J), [2]
    return two, (driven_J, other_J), [1]


def chain_model_xml(plant: ChainPlant, inertias_kgm2: Sequence[float], driven: Sequence[int], *,
                    timestep_s: float = 1e-4, header: str = "", kind: str = HINGE) -> str:
    """The MJCF text of a chain that :func:`load_chain` reads back to ``plant`` with these
    inertias (kg m^2; a slide's masses, kg): coaxial hinges ``phi1..phiN`` (``kind="slide"``:
    slides ``x1..xN`` on one axis) with position and rate sensors, a motor ``drive<i>`` with its
    torque (force) sensor on every driven body, the laws as ``jointrig_joint<j>_*`` and
    ``jointrig_ground<i>_*`` fields and nonzero drags as ``jointrig_bearing<i>_*`` (a slide's
    ``guide<i>_*``), a slide's names in N and m (:func:`vocab.params.linear_name`). For a
    measured train without the user's model file, and to write an identified train back."""
    try:
        kind = Coordinate(kind)
    except ValueError as err:
        raise ValueError(f"chain_model_xml: kind: {err}") from None
    name, coord = kind.name, kind.position
    N = plant.n_flywheels
    if len(inertias_kgm2) != N:
        raise ValueError(f"chain_model_xml: {len(inertias_kgm2)} inertias for {N} flywheels")
    bad = [i for i, J in enumerate(inertias_kgm2, start=1) if not (math.isfinite(J) and J > 0)]
    if bad:
        raise ValueError(f"chain_model_xml: the inertia of flywheel(s) {bad} must be > 0, got "
                         f"{[inertias_kgm2[i - 1] for i in bad]}")
    driven = sorted(set(int(i) for i in driven))
    if not driven or not all(1 <= i <= N for i in driven):
        raise ValueError(f"chain_model_xml: driven flywheels must be among 1..{N}, got {driven}")
    fields: dict[str, list[float]] = {}
    places = [(f"joint{j}_", f"joint {j}", law) for j, law in enumerate(plant.laws, start=1)]
    places += [(f"ground{i}_", f"body {i}'s law to ground", g) for i, g in enumerate(plant.grounds, start=1)
               if g is not None]
    for prefix, where, law in places:
        for term, value in zip(law.terms, law.values):
            try:
                fields.update({prefix + name(k): v for k, v in term.fields(value).items()})
            except FieldError as err:
                raise ValueError(f"chain_model_xml: {where}: {err}") from None
    for i, b in enumerate(plant.bearings_Nms_per_rad, start=1):
        if b:
            fields[name(f"bearing{i}_damping_Nms_per_rad")] = [b]
    if plant.drive_delay_s:
        fields[DRIVE_DELAY] = [plant.drive_delay_s]
    numerics = "\n".join(f'    <numeric name="{PREFIX}{k}" data="{" ".join(repr(float(x)) for x in v)}"/>'
                         for k, v in fields.items())
    bodies = "\n".join(
        f'    <body name="body{i}" pos="0 {0.3 * (i - 1):g} 0">\n'
        f'      <joint name="{coord}{i}" type="{kind}" axis="0 0 1" damping="0" armature="0"/>\n'
        f'      {_INERTIAL[kind](J)}\n'
        f'    </body>' for i, J in enumerate(inertias_kgm2, start=1))
    motors = "\n".join(f'    <motor name="drive{i}" joint="{coord}{i}" gear="1" ctrllimited="false"/>' for i in driven)
    sensors = "\n".join([f'    <jointpos name="{coord}{i}" joint="{coord}{i}"/>' for i in range(1, N + 1)]
                        + [f'    <jointvel name="rate{i}" joint="{coord}{i}"/>' for i in range(1, N + 1)]
                        + [f'    <actuatorfrc name="drive{i}_torque" actuator="drive{i}"/>' for i in driven])
    comment = "\n".join("  " + line.replace("--", "- -") for line in header.splitlines())
    return ((f"<!--\n{comment}\n-->\n" if header else "")
            + f'<mujoco model="train{N}">\n  <compiler angle="radian"/>\n'
            f'  <option timestep="{timestep_s!r}" integrator="RK4" gravity="0 0 0">\n'
            f'    <flag contact="disable"/>\n  </option>\n'
            + (f"  <custom>\n{numerics}\n  </custom>\n" if numerics else "")
            + f"  <worldbody>\n{bodies}\n  </worldbody>\n  <actuator>\n{motors}\n  </actuator>\n"
            f"  <sensor>\n{sensors}\n  </sensor>\n</mujoco>\n")


def _split_law(law: JointLaw, state: list) -> tuple:
    """A law as the callback evaluates it: its stateless terms' torque, and per slider term
    ``(step_torque, value, first state)`` over ``state`` (committed by the caller)."""
    stateless = [(t, x) for t, x in zip(law.terms, law.values) if not t.stateful]
    torque = (JointLaw(tuple(t for t, _ in stateless), tuple(x for _, x in stateless)).torque
              if stateless else (lambda phi, rate: 0.0))
    hyst, at = [], 0
    for t, x in zip(law.terms, law.values):
        if t.stateful:
            hyst.append((t.step_torque, x, at))
            at += t.n_states
    return torque, hyst, state


def chain_callback(rig: ChainRig, plant: ChainPlant, drives: dict, errors: list, states: list,
                   ground_states: Sequence = ()) -> Callable:
    """The passive callback of a chain: every joint's law, the bearings, every body's law to
    ground, the drives at continuous time. ``states[j]`` holds joint j's slider states and
    ``ground_states[i]`` body i's (0-based; committed by the caller)."""
    q, v = rig.qpos_adr, rig.dof_adr
    ground_states = list(ground_states) or [[] for _ in plant.grounds]
    joints = [(q[j], q[j + 1], v[j], v[j + 1]) + _split_law(law, states[j]) for j, law in enumerate(plant.laws)]
    bearings = [(v[i], b) for i, b in enumerate(plant.bearings_Nms_per_rad) if b]
    grounds = [(q[i], v[i]) + _split_law(g, ground_states[i]) for i, g in enumerate(plant.grounds) if g is not None]
    acts = [(a, drives[i].evaluator()) for i, a, _ in rig.drives if i in drives]

    def callback(m, d):
        try:
            qpos, qvel, frc = d.qpos, d.qvel, d.qfrc_passive
            for qa, qb, va, vb, torque, hyst, st in joints:
                phi = float(qpos[qa] - qpos[qb])
                tau = torque(phi, float(qvel[va] - qvel[vb]))
                for f, x, i in hyst:
                    tau += x * f(phi, st, i)
                frc[va] -= tau
                frc[vb] += tau
            for va, b in bearings:
                frc[va] -= b * qvel[va]
            for qa, va, torque, hyst, st in grounds:
                phi = float(qpos[qa])
                tau = torque(phi, float(qvel[va]))
                for f, x, i in hyst:
                    tau += x * f(phi, st, i)
                frc[va] -= tau
            t = d.time
            for a, at in acts:
                d.ctrl[a] = at(t)
        except Exception as err:  # noqa: BLE001 - re-raised after the step
            if not errors:
                errors.append(err)

    return callback


def simulate_chain(rig: ChainRig, omega_rad_s: float, drives: dict, config: SimulationConfig = SimulationConfig(), *,
                   plant: Optional[ChainPlant] = None, inertias_kgm2: Optional[Sequence[float]] = None,
                   amplitude_Nm: float = math.nan, backend: str = "auto",
                   start: Optional[tuple] = None, loads_Nm: Sequence[float] = ()) -> tuple[ChainRecord, SettleInfo]:
    """Drive the chain from rest (or from ``start``) to steady state and log ``config.n_periods``
    whole periods.

    Args:
      drives: flywheel number -> :class:`vocab.plant.PeriodicDrive` (fundamental
        ``omega_rad_s``); every number must have a ``drive<i>`` motor in the model.
      plant: laws and bearings to simulate instead of the file's; inertias_kgm2: inertias
        instead of the file's (each body's inertia scaled).
      amplitude_Nm: a label for the record.
      backend: ``"native"``: every joint's law, the bearings and the drives in the compiled C
        callback (rig/native_callback.py ``NativeChain``): the Python callback's records to 1e-8; a chain
        without sliders is integrated a period per ``mujoco.rollout`` call (no Python between
        steps). ``"python"``: the Python callback; ``"auto"`` (the default): native wherever the
        machine can build it and it knows every law's terms
        (:func:`rig.native_callback.choose_native`).
      start: ``(angles, rates)``, one per body at t = 0 (a measured record's, rad and rad/s, or
        m and m/s): the replay begins on the measured motion. A law that depends on where a body
        is (a motor's cogging to ground, a free play) may have several steady states, and the one
        measured is the one reached from there. The rigid rotation of a train free to turn keeps
        the drive's mean-free velocity (the measured rates' relative parts are added to it).
      loads_Nm: a constant torque (N m; N on a slide) on each body, or none: a mean load and
        what holds a preload (MuJoCo's ``qfrc_applied``). On a train free to turn they must sum
        to 0, or it spins up.

    Without ``start`` the flywheels start at rest with the common velocity that keeps the rigid rotation periodic
    (:meth:`PeriodicDrive.mean_free_impulse` summed over the drives, over the total inertia).
    Steady state is declared by :func:`rig.simulate.settle_bound` on the relative angles, the
    rates and (with ``config.absolute_angles_periodic``) the absolute angles.
    """
    if not (math.isfinite(omega_rad_s) and omega_rad_s > 0):
        raise ValueError(f"omega_rad_s must be a finite number > 0, got {omega_rad_s}")
    if not drives:
        raise ValueError("drives: give at least one flywheel number -> PeriodicDrive")
    for i, drv in drives.items():
        if i not in rig.driven:
            raise ValueError(f"drives: flywheel {i} has no motor in {rig.path.name} (driven: {list(rig.driven)})")
        if abs(drv.omega_rad_s - omega_rad_s) > 1e-12 * omega_rad_s:
            raise ValueError(f"drive on flywheel {i}: fundamental {drv.omega_rad_s} differs from {omega_rad_s}")
    plant = rig.plant if plant is None else plant
    if plant.n_flywheels != rig.n_flywheels:
        raise ValueError(f"plant of {plant.n_flywheels} flywheels for a chain of {rig.n_flywheels}")
    recorded = drives
    if plant.drive_delay_s:  # the drives act later than recorded: each periodic drive turned by its delay
        drives = {i: d.delayed(plant.drive_delay_s) for i, d in drives.items()}
    grounded = any(g is not None for g in plant.grounds)
    native = choose_native(backend, tuple(plant.laws) + tuple(g for g in plant.grounds if g is not None))
    N = rig.n_flywheels
    m = copy.copy(rig.model)
    # A body's dry friction to ground is held by MuJoCo's own constraint on its joint (the
    # dof's frictionloss), as the two-flywheel rig holds the joint's: in the callback, sign(rate)
    # would chatter while the body sticks. The callback keeps the continuous rest.
    split = [dry_friction_split(g) if g is not None else (None, 0.0) for g in plant.grounds]
    if any(static > 0 for _, static in split):
        plant = replace(plant, grounds=tuple(p.law if p is not None else None for p, _ in split))
        for i, (_, static) in enumerate(split):
            dof = rig.dof_adr[i]
            m.dof_frictionloss[dof] = static
            m.dof_solref[dof] = TWIST_SOLREF  # the two-flywheel rig's stiff friction constraint
            m.dof_solimp[dof] = TWIST_SOLIMP
    # A joint's is held by the constraint on its twist tendon.
    at_joints = [dry_friction_split(law) for law in plant.laws]
    if any(static > 0 for _, static in at_joints):
        plant = replace(plant, laws=tuple(p.law for p, _ in at_joints))
        for j, (_, static) in enumerate(at_joints):
            m.tendon_frictionloss[rig.twist_tendons[j]] = static
    J = rig.inertias_kgm2
    if inertias_kgm2 is not None:
        if len(inertias_kgm2) != N or not all(math.isfinite(x) and x > 0 for x in inertias_kgm2):
            raise ValueError(f"inertias_kgm2 must be {N} finite numbers > 0, got {inertias_kgm2}")
        set_inertias(m, rig.dof_adr, inertias_kgm2, rig.inertias_kgm2)
        J = tuple(float(x) for x in inertias_kgm2)
    where = f"{rig.path.name} at omega = {omega_rad_s:g} rad/s"
    t_start = _time.perf_counter()
    m.opt.integrator = mujoco.mjtIntegrator.__members__[config.mj_integrator_name]
    m.opt.timestep = config.timestep_s(omega_rad_s)
    k = config.steps_per_sample(omega_rad_s)
    n = config.samples_for(omega_rad_s)
    d = mujoco.MjData(m)
    if len(loads_Nm):
        if len(loads_Nm) != N or not all(math.isfinite(x) for x in loads_Nm):
            raise ValueError(f"loads_Nm must be {N} finite numbers, got {loads_Nm}")
        d.qfrc_applied[list(rig.dof_adr)] = loads_Nm
    d.qvel[list(rig.dof_adr)] = sum(drv.mean_free_impulse(0.0) for drv in drives.values()) / sum(J)
    if start is not None:
        angles, rates = (np.asarray(x, dtype=float) for x in start)
        if angles.shape != (N,) or rates.shape != (N,) or not (np.all(np.isfinite(angles))
                                                               and np.all(np.isfinite(rates))):
            raise ValueError(f"start: one finite angle and rate per body ({N}), got {start}")
        d.qpos[list(rig.qpos_adr)] = angles
        if grounded:  # tied to the frame: no rigid rotation to keep free of drift
            d.qvel[list(rig.dof_adr)] = rates
        else:
            d.qvel[list(rig.dof_adr)] += rates - float(np.dot(J, rates)) / sum(J)
    states = [[0.0] * sum(t.n_states for t in law.terms if t.stateful) for law in plant.laws]
    ground_states = [[0.0] * sum(t.n_states for t in g.terms if t.stateful) if g is not None else []
                     for g in plant.grounds]
    # (angle of, minus angle of or None, its slider terms, their states): joints' then grounds'
    stateful = [(j, j + 1, [t for t in law.terms if t.stateful], states[j]) for j, law in enumerate(plant.laws)]
    stateful += [(i, None, [t for t in g.terms if t.stateful], ground_states[i])
                 for i, g in enumerate(plant.grounds) if g is not None]
    stateful = [x for x in stateful if x[2]]
    errors: list = []
    q, v = np.array(rig.qpos_adr), np.array(rig.dof_adr)
    act_idx = {i: adr for i, _, adr in rig.drives}

    # sliders stepped in C read the state from the sensors: a model without every position and
    # rate sensor runs them in the Python callback
    sensed = list(rig.angle_adr) + list(rig.rate_adr) + [act_idx[i] for i in sorted(act_idx)]
    native = native and not (stateful and None in sensed)
    nat = None
    if native:
        nat = NativeChain(rig, plant, drives)
        callback = nat.function

    else:
        callback = chain_callback(rig, plant, drives, errors, states, ground_states)

        def commit():
            for a, b, terms, st in stateful:
                phi = float(d.qpos[q[a]] - (d.qpos[q[b]] if b is not None else 0.0))
                at = 0
                for t in terms:
                    t.commit(phi, st, at)
                    at += t.n_states

    def period():
        pos, vel, tq, tbuf = np.empty((n, N)), np.empty((n, N)), np.empty((n, N)), np.empty(n)
        for s in range(n):
            tbuf[s] = d.time
            pos[s] = d.qpos[q]  # the state at tbuf[s] (what jointpos/jointvel sensors read in the step)
            vel[s] = d.qvel[v]
            mujoco.mj_step(m, d)  # actuatorfrc sensors now hold the torque applied at tbuf[s]
            tq[s] = [d.sensordata[act_idx[i]] if i in act_idx else 0.0 for i in range(1, N + 1)]
            if stateful:
                commit()
            for _ in range(k - 1):
                mujoco.mj_step(m, d)
                if stateful:
                    commit()
        return pos, vel, tq, tbuf

    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    sens = [act_idx.get(i) for i in range(1, N + 1)]
    applied_spec = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_QFRC_APPLIED
    applied = np.empty(mujoco.mj_stateSize(m, applied_spec))
    mujoco.mj_getState(m, d, applied, applied_spec)

    def rollout_period():
        # One C call per period: row j of `st` is the state after step j, row j of `sd` the
        # sensors computed in step j (at the state before it), as the stepped loop records.
        from mujoco import rollout

        mujoco.mj_getState(m, d, state, spec)
        if len(loads_Nm):  # a rollout sets every step's inputs it is given, and clears the rest
            st, sd = rollout.rollout(m, d, state[None], applied[None, None], control_spec=applied_spec, nstep=n * k)
        else:
            st, sd = rollout.rollout(m, d, state[None], nstep=n * k)
        before = np.vstack([state[None], st[0, :-1]])[::k]  # the state before each sample's first step
        mujoco.mj_setState(m, d, st[0, -1], spec)
        tq = np.column_stack([sd[0, ::k, a] if a is not None else np.zeros(n) for a in sens])
        return before[:, 1 + q], before[:, 1 + m.nq + v], tq, before[:, 0]

    def native_period():
        # One C call per period, the sliders committed after every step (rig/native/jointrig_law.c,
        # jointrig_run): the sensors after each sample's first step are the state before it.
        buf, tbuf = nat.run(m, d, n, k, np.array(sensed))
        tq = np.zeros((n, N))
        for c, i in enumerate(sorted(act_idx)):
            tq[:, i - 1] = buf[:, 2 * N + c]
        return buf[:, :N], buf[:, N:2 * N], tq, tbuf

    advance = (rollout_period if not stateful else native_period) if native else period
    absolute = config.absolute_angles_periodic
    names = (tuple(f"phi{j} - phi{j + 1}" for j in range(1, N)) + tuple(f"rate{i}" for i in range(1, N + 1))
             + (tuple(f"phi{i}" for i in range(1, N + 1)) if absolute else ()))

    elastic = [i for i, g in enumerate(plant.grounds) if g is not None and any(t.elastic for t in g.terms)]
    names += tuple(f"phi{i + 1}" for i in elastic if not absolute)

    def watched(payload):
        pos, vel = payload[0], payload[1]
        return np.column_stack([pos[:, :-1] - pos[:, 1:], vel] + ([pos] if absolute else [pos[:, elastic]]))

    def failure():
        if errors:
            return errors[0]
        if nat is not None and nat.error:
            return SimulationError("the native callback met a term it does not know")
        return None

    # Inside a native_session the callback is installed already (shared by threads; each
    # simulation finds its own blocks by its MjData).
    installed = contextlib.nullcontext() if native and session_active() else passive_callback(callback)
    with installed, _activated(nat, d):
        periods, (p, change, bound, ratio) = _settle(
            advance, watched, names, lambda pl: bool(np.all(np.isfinite(pl[0])) and np.all(np.isfinite(pl[1]))),
            failure, config, d, where, t_start,
            _Jump(d, rig.qpos_adr, rig.dof_adr, J, free=not any(b > 0 for b in plant.bearings_Nms_per_rad))
            if config.accelerate and not stateful and not grounded else None)
    pos = np.vstack([x[0] for x in periods]).T
    vel = np.vstack([x[1] for x in periods]).T
    tq = np.vstack([x[2] for x in periods]).T
    t_rec = np.concatenate([x[3] for x in periods])
    if plant.drive_delay_s:  # the record holds the drive as recorded, not as it acts
        tq = np.array([recorded[i + 1](t_rec) if (i + 1) in recorded else np.zeros(t_rec.size) for i in range(N)])
    measured = [a is not None for a in rig.angle_adr]
    rated = [a is not None for a in rig.rate_adr]
    record = ChainRecord(
        omega_rad_s=float(omega_rad_s), time_s=t_rec,
        torques_Nm=tuple(tq[i] if (i + 1) in drives else None for i in range(N)),
        angles_rad=tuple(pos[i] if measured[i] else None for i in range(N)),
        rates_rad_s=tuple(vel[i] if rated[i] and measured[i] else None for i in range(N)),
        n_periods=config.n_periods, drive_amplitude_Nm=float(amplitude_Nm), source=where)
    info = SettleInfo(periods_simulated=p, last_change=change, timestep_s=m.opt.timestep,
                      wall_time_s=_time.perf_counter() - t_start, error_bound=bound, decay_ratio=ratio)
    return record, info

