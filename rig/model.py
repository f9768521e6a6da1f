"""Loading a rig model: the MJCF file says everything (bodies, drive, sensors, joint law)."""

from __future__ import annotations

import dataclasses

import hashlib
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Union

import mujoco
import numpy as np

from jointrig.vocab.law import TERM_CLASSES, FieldError, JointLaw, law_terms_from_fields
from jointrig.vocab.plant import Plant
from jointrig.vocab.params import BEARING1, BEARING2, DRIVE_DELAY
from jointrig.vocab.records import MAX_SI_VALUE

__all__ = ["RigModel", "RigModelError", "load_rig", "law_from_model", "plant_from_model", "DEFAULT_MODEL", "TWIST_TENDON"]

DEFAULT_MODEL = Path(__file__).resolve().parent.parent / "models" / "two_flywheels.xml"

#: Names every jointrig model must have (joints, actuator, sensors).
JOINTS = ("phi1", "phi2")
ACTUATOR = "drive"
SENSORS = {"phi1": "jointpos", "phi2": "jointpos", "rate1": "jointvel", "rate2": "jointvel",
           "drive_torque": "actuatorfrc"}
_SENSOR_TYPES = {"jointpos": mujoco.mjtSensor.mjSENS_JOINTPOS,
                 "jointvel": mujoco.mjtSensor.mjSENS_JOINTVEL,
                 "actuatorfrc": mujoco.mjtSensor.mjSENS_ACTUATORFRC}

PREFIX = "jointrig_"
#: A chain model's per-joint law field, without the prefix: ``joint<j>_<field>`` (rig/chain.py).
JOINT_FIELD = re.compile(r"joint(\d+)_(.+)")
#: A field only a chain model has: a joint's law, a body's law to ground, a slide's drag (a
#: two-flywheel model has bearing1_, bearing2_ too).
CHAIN_FIELD = re.compile(r"(?:joint|ground|guide)\d+_.+")
#: Fields of the plant outside the joint law (the law's own fields are its terms': TERM_CLASSES).
_PLANT_FIELDS = (BEARING1, BEARING2, DRIVE_DELAY)


def _known_fields() -> tuple[str, ...]:
    return tuple(f for cls in TERM_CLASSES for f in cls.MJCF_FIELDS) + _PLANT_FIELDS


class RigModelError(ValueError):
    """The MJCF file is not a usable jointrig model (names the file and what is missing)."""


@dataclass(frozen=True, eq=False)
class RigModel:
    """A compiled rig with the addresses the callback and the logger need.

    Attributes:
      path: the MJCF file.
      model: the compiled ``mujoco.MjModel`` (compiled once, before any callback is installed).
      law: the joint law read from the file's ``jointrig_*`` numeric fields.
      plant: the law plus bearing drag and drive delay (``jointrig_bearing1_damping_Nms_per_rad``,
        ``..._bearing2_...``, ``jointrig_drive_delay_s``); the law's fields are those its term
        classes read (``MJCF_FIELDS`` of :data:`vocab.law.TERM_CLASSES`: c, k, a, gamma,
        dry friction, quadratic damping, free play, hat knots, Jenkins and Iwan elements).
      J1_kgm2, J2_kgm2: flywheel inertias about the hinge axis (from the compiled mass matrix).
      qpos_adr, dof_adr: addresses of phi1 and phi2 in qpos and qvel.
      actuator_id: the drive motor.
      sensor_adr: sensor name -> address in sensordata.
      digest: SHA-256 of the file (ties stored sweep results to the model that made them).
      twist_tendon: the fixed tendon ``phi1 - phi2`` the rig adds to the file's bodies
        (:data:`TWIST_TENDON`): its ``frictionloss`` holds the joint's dry friction as a
        constraint (:func:`rig.simulate.dry_friction_split`); 0 in the compiled model, so a law
        without dry friction is simulated as the file has it.
    """

    path: Path
    model: mujoco.MjModel
    law: JointLaw
    plant: Plant
    J1_kgm2: float
    J2_kgm2: float
    qpos_adr: tuple[int, int]
    dof_adr: tuple[int, int]
    actuator_id: int
    sensor_adr: dict
    digest: str
    twist_tendon: int = -1

    @property
    def Je_kgm2(self) -> float:
        """Equivalent inertia ``J1 J2 / (J1 + J2)`` (paper eq. 11)."""
        return self.J1_kgm2 * self.J2_kgm2 / (self.J1_kgm2 + self.J2_kgm2)

    @property
    def torque_share(self) -> float:
        """``J2 / (J1 + J2)``: the part of the drive torque that strains the joint."""
        return self.J2_kgm2 / (self.J1_kgm2 + self.J2_kgm2)

    def with_plant(self, plant: Union[Plant, JointLaw]) -> "RigModel":
        """The same rig simulating another law (or plant) than its file declares."""
        plant = Plant.of(plant)
        return dataclasses.replace(self, law=plant.law, plant=plant)


#: The fixed tendon ``phi1 - phi2`` :func:`load_rig` adds to a two-flywheel model: dry friction
#: in the joint is its ``frictionloss``, which MuJoCo solves as a constraint, so a sticking joint
#: stays stuck (a ``sign(rate)`` torque in the passive callback chatters while it sticks, and the
#: rig then finds no periodic steady state).
TWIST_TENDON = "jointrig_twist"
#: The constraint's softness: MuJoCo clamps the time constant to two steps (its ``refsafe``),
#: so the friction acts over the shortest time the step allows; an impedance of 0.9999 lets a
#: stuck joint creep by 1e-4 of the acceleration it would have free. Measured against the
#: independent bench's event-driven Coulomb friction (``tests/test_dry_friction_rig.py``).
TWIST_SOLREF = (1e-6, 1.0)
TWIST_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


def with_twist_tendons(path: Path, source: str, tendons) -> mujoco.MjModel:
    """The file's model with fixed tendons ``(name, joint a, joint b)`` of length ``a - b``
    added (frictionloss 0, the stiff friction constraint :data:`TWIST_SOLREF`): the rig holds a
    joint's dry friction as their ``frictionloss``. A tendon of the file with one of those names
    is refused, naming it."""
    # MuJoCo picks the file's decoder by its suffix: a model written under another name (an
    # atomic writer's temporary file) is read from its text.
    spec = (mujoco.MjSpec.from_file(str(path)) if path.suffix.lower() == ".xml"
            else mujoco.MjSpec.from_string(path.read_text(encoding="utf-8")))
    ours = {name for name, _, _ in tendons}
    for t in spec.tendons:
        if t.name in ours:
            raise RigModelError(f"{source}: a tendon named '{t.name}' is the rig's own (dry friction in a joint); "
                                f"rename yours")
    for name, a, b in tendons:
        tendon = spec.add_tendon(name=name, frictionloss=0.0, solref_friction=list(TWIST_SOLREF),
                                 solimp_friction=list(TWIST_SOLIMP))
        tendon.wrap_joint(a, 1.0)
        tendon.wrap_joint(b, -1.0)
    return spec.compile()


def _numeric_fields(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    return {model.numeric(i).name: np.array(model.numeric(i).data, dtype=float)
            for i in range(model.nnumeric)}


def law_from_model(model: mujoco.MjModel, source: str = "model") -> JointLaw:
    """The joint law a model declares in its ``jointrig_*`` ``<custom><numeric>`` fields (each
    term class reads its own: :data:`vocab.law.TERM_CLASSES`)."""
    fields = {k[len(PREFIX):]: v for k, v in _numeric_fields(model).items() if k.startswith(PREFIX)}
    known = _known_fields()
    unknown = sorted(set(fields) - set(known))
    if unknown:
        raise RigModelError(f"{source}: unknown joint-law field(s) {[PREFIX + u for u in unknown]}; expected "
                            f"{[PREFIX + f for f in known]}")
    try:
        pairs = law_terms_from_fields(fields)
    except FieldError as err:
        raise RigModelError(f"{source}: {err}") from None
    if not pairs:
        raise RigModelError(f"{source}: no joint law: add <custom><numeric name=\"{PREFIX}...\"> fields "
                            f"(e.g. {PREFIX}k_Nm_per_rad)")
    for term, value in pairs:
        if abs(value) > MAX_SI_VALUE:
            raise RigModelError(f"{source}: the law's {term.name} = {value:g} is beyond {MAX_SI_VALUE:g} in SI units, "
                                f"no joint's (a unit slip, such as N mm for N m?); expected SI units")
    return JointLaw(tuple(t for t, _ in pairs), tuple(v for _, v in pairs))


def plant_from_model(model: mujoco.MjModel, source: str = "model") -> Plant:
    """The law plus the effects outside the joint (bearing drag, drive delay) a model declares."""
    law = law_from_model(model, source)
    fields = {k[len(PREFIX):]: v for k, v in _numeric_fields(model).items() if k.startswith(PREFIX)}
    def get(name: str) -> float:
        data = fields.get(name, np.zeros(1))
        if data.size != 1 or not np.isfinite(data[0]) or data[0] < 0:
            raise RigModelError(f"{source}: {PREFIX}{name} must hold one finite number >= 0, got {data}")
        return float(data[0])

    return Plant(law, bearing1_damping_Nms_per_rad=get(BEARING1),
                 bearing2_damping_Nms_per_rad=get(BEARING2),
                 drive_delay_s=get(DRIVE_DELAY))


def _find(model, obj, name, what, source):
    i = mujoco.mj_name2id(model, obj, name)
    if i < 0:
        raise RigModelError(f"{source}: no {what} named '{name}'; a jointrig model needs hinge joints "
                            f"{list(JOINTS)}, motor '{ACTUATOR}' on 'phi1' and sensors {SENSORS}")
    return i


def is_chain_model(path: Union[str, os.PathLike]) -> bool:
    """True if the model file declares a chain's laws (``jointrig_joint<j>_*``, ``ground<i>_*``,
    ``bearing<i>_*`` fields)."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return False
    return any(CHAIN_FIELD.fullmatch(n.get("name", "")[len(PREFIX):] or "")
               for n in root.iter("numeric") if n.get("name", "").startswith(PREFIX))


def compile_model(path: Union[str, os.PathLike]) -> tuple[Path, bytes, mujoco.MjModel]:
    """The file's path, its bytes (for the digest) and the compiled model (before any passive
    callback is installed). Raises :class:`RigModelError` naming the file."""
    path = Path(path)
    if not path.is_file():
        raise RigModelError(f"{path}: no such model file")
    text = path.read_bytes()
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as err:
        raise RigModelError(f"{path}: MuJoCo could not compile it: {err}") from None
    return path, text, model


def load_rig(path: Union[str, os.PathLike] = DEFAULT_MODEL) -> RigModel:
    """Compile and check a rig model.

    Raises:
      RigModelError: missing file, MJCF that does not compile, missing or mistyped joints,
        drive or sensors, or an invalid joint law; the message names the file and the item.
    """
    if is_chain_model(path):
        raise RigModelError(f"{path}: a chain model (jointrig_joint<j>_* fields): load it with "
                            f"rig.chain.load_chain, which checks the chain (jointrig sweep, design and "
                            f"diagnose-chain take it)")
    path, text, model = compile_model(path)
    src = str(path)
    joint_ids = [_find(model, mujoco.mjtObj.mjOBJ_JOINT, j, "joint", src) for j in JOINTS]
    for name, jid in zip(JOINTS, joint_ids):
        if model.jnt_type[jid] != mujoco.mjtJoint.mjJNT_HINGE:
            raise RigModelError(f"{src}: joint '{name}' must be a hinge, got {mujoco.mjtJoint(model.jnt_type[jid]).name}")
    if not np.allclose(model.jnt_axis[joint_ids[0]], model.jnt_axis[joint_ids[1]]):
        raise RigModelError(f"{src}: joints 'phi1' and 'phi2' must share their axis (coaxial flywheels)")
    for name, jid in zip(JOINTS, joint_ids):
        dof = model.jnt_dofadr[jid]
        own = {"damping": model.dof_damping[dof], "frictionloss": model.dof_frictionloss[dof],
               "stiffness": model.jnt_stiffness[jid], "armature": model.dof_armature[dof]}
        set_fields = {k: float(v) for k, v in own.items() if v != 0.0}
        if set_fields:
            raise RigModelError(f"{src}: joint '{name}' sets MuJoCo's own {', '.join(f'{k}={v:g}' for k, v in set_fields.items())}: "
                                f"the rig applies the joint law from the jointrig_* fields and would add these on "
                                f"top, counting them twice or where the law does not say; state them as jointrig "
                                f"fields (damping between the flywheels: jointrig_c_Nms_per_rad; to ground: "
                                f"jointrig_bearing1_damping_Nms_per_rad; dry friction: jointrig_coulomb_torque_Nm; "
                                f"inertia: the body's) and set them to 0 here")
    act = _find(model, mujoco.mjtObj.mjOBJ_ACTUATOR, ACTUATOR, "actuator", src)
    if model.actuator_trnid[act, 0] != joint_ids[0]:
        raise RigModelError(f"{src}: actuator '{ACTUATOR}' must drive joint 'phi1'")
    if model.actuator_ctrllimited[act]:
        raise RigModelError(f"{src}: actuator '{ACTUATOR}' must not be ctrllimited (the drive "
                            f"torque would be clipped silently)")
    sensor_adr = {}
    for name, kind in SENSORS.items():
        sid = _find(model, mujoco.mjtObj.mjOBJ_SENSOR, name, "sensor", src)
        if model.sensor_type[sid] != _SENSOR_TYPES[kind]:
            raise RigModelError(f"{src}: sensor '{name}' must be a {kind} sensor")
        sensor_adr[name] = int(model.sensor_adr[sid])
    plant = plant_from_model(model, src)
    law = plant.law
    model = with_twist_tendons(path, src, ((TWIST_TENDON, JOINTS[0], JOINTS[1]),))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mass = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass)
    dofs = tuple(int(model.jnt_dofadr[j]) for j in joint_ids)
    if abs(mass[dofs[0], dofs[1]]) > 1e-12 * mass[dofs[0], dofs[0]]:
        raise RigModelError(f"{src}: flywheels must not be inertially coupled (bodies in a chain?)")
    return RigModel(
        path=path, model=model, law=law, plant=plant,
        J1_kgm2=float(mass[dofs[0], dofs[0]]), J2_kgm2=float(mass[dofs[1], dofs[1]]),
        qpos_adr=tuple(int(model.jnt_qposadr[j]) for j in joint_ids), dof_adr=dofs,
        actuator_id=int(act), sensor_adr=sensor_adr, digest=hashlib.sha256(text).hexdigest(),
        twist_tendon=int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TENDON, TWIST_TENDON)),
    )


def identified_model_xml(plant: Plant, inertias_kgm2: tuple[float, float], *, template: Union[str, os.PathLike] = DEFAULT_MODEL,
                         header: str = "") -> str:
    """The MJCF text of a rig that simulates ``plant`` with flywheel inertias (J1, J2): the
    template's bodies, drive and sensors, its ``jointrig_*`` fields replaced by the plant's and
    the flywheels' hinge-axis inertias set to J1, J2 (``diaginertia`` z). ``header`` becomes a
    comment at the top (what was identified, from what). Every field written is one that
    :func:`load_rig` reads back to the same plant (tested)."""

    template = Path(template)
    root = ET.fromstring(template.read_text(encoding="utf-8"))
    fields: dict[str, list[float]] = {}
    for term, value in zip(plant.law.terms, plant.law.values):
        try:
            fields.update(term.fields(value))
        except FieldError as err:
            raise ValueError(f"identified_model_xml: {err}") from None
    for name in _PLANT_FIELDS:
        if getattr(plant, name):
            fields[name] = [getattr(plant, name)]
    custom = root.find("custom")
    if custom is None:
        custom = ET.SubElement(root, "custom")
    for numeric in list(custom.findall("numeric")):
        if numeric.get("name", "").startswith(PREFIX):
            custom.remove(numeric)
    for name, data in fields.items():
        ET.SubElement(custom, "numeric", name=PREFIX + name, data=" ".join(repr(float(v)) for v in data))
    for joint_name, J in zip(("phi1", "phi2"), inertias_kgm2):
        if not (math.isfinite(J) and J > 0):
            raise ValueError(f"identified_model_xml: inertia of {joint_name} must be > 0, got {J!r}")
        body = next((b for b in root.iter("body") if any(j.get("name") == joint_name for j in b.findall("joint"))),
                    None)
        inertial = body.find("inertial") if body is not None else None
        if inertial is None or inertial.get("diaginertia") is None:
            raise ValueError(f"{template}: the body of hinge {joint_name!r} needs an <inertial diaginertia=...>")
        d = [float(v) for v in inertial.get("diaginertia").split()]
        # Only the hinge-axis inertia matters; the others keep the triangle inequality A + B >= C.
        side = max(d[0], d[1], 0.5 * J * (1 + 1e-9))
        inertial.set("diaginertia", f"{side!r} {side!r} {J!r}")
    ET.indent(root, space="  ")
    text = ET.tostring(root, encoding="unicode")
    comment = "\n".join("  " + line.replace("--", "- -") for line in header.splitlines())
    return (f"<!--\n{comment}\n-->\n" if header else "") + text + "\n"
