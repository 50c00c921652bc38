"""A robot's URDF in, a stride's joint-space file and its controller specification out, and a
controller written from those files alone walking the robot in MuJoCo.

The robot is tests/robot_urdf.py's (base-rooted, its own encoder senses). The product reads
its URDF (problems.robot.walker_from_urdf), plans a step on point feet and one on feet with
their feedback, and writes joints.csv with its sidecar. Everything below the planning is
written the way a robot team would, from the files and the robot's own description only: the
MJCF is built here from the robot's numbers (not by model.to_mjcf), the controller reads
joints.csv with numpy and the sidecar with json, maps its encoders with the sidecar's sign
and zero, measures the phase on the robot's kinematics, detects strikes from contact forces
and runs the law the sidecar states. It must walk 20 steps on point feet (the robot given
0.5 kg soles the plan does not know, the swing sole held level as the sidecar says), on point
feet with a double support (its feedback waiting out the soft touchdown as the sidecar says)
and on feet; a controller that swaps the rows but skips the gains must fall, and so must one
that skips the touchdown's wait (the test can fail).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from robot_urdf import SIDES, biped_urdf

from model import LinkageTrajectory
from model.anthropometry import FOOT_COM, FootGeometry
from model.linkage import Linkage
from model.presets import SIX_LINK_TABLE
from problems import footed_step, walking_step
from problems.control.feedback import design_feedback
from problems.control.feet_law import FeetLaw
from problems.human.joints import body_of, joint_radians, leg_moments
from problems.robot import joint_space, walker_from_urdf

mujoco = pytest.importorskip("mujoco")

RATE_HZ = 1000.0
TIMESTEP = 0.0005
SPHERE = 0.005  # contact spheres' radius, m
POINT_SOLE = (0.05, 0.15)  # the point-foot robot's sole behind and ahead of the ankle, m
POINT_FOOT_MASS = 0.5


# ---- the product: URDF in, files out -------------------------------------------------------
def _files(tmp_path, feet: bool, double_support: float = 0.0):
    """(joints.csv path, its sidecar path) of the test robot's planned step with feedback."""
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(biped_urdf(feet))
    walker = walker_from_urdf(urdf.read_text())
    if feet:
        gait = footed_step(walker.linkage, points=walker.points).solve()
        profile = FeetLaw(gait, rate_hz=RATE_HZ).channels(gait.to_trajectory(RATE_HZ))
    else:
        gait = walking_step(walker.linkage, double_support=double_support).solve()
        feedback = design_feedback(gait, ground_mu=1.5 if double_support else 1.0)
        profile = feedback.channels(gait.to_trajectory(RATE_HZ))
    profile = profile.with_metadata(robot=walker.metadata(str(urdf)))
    profile.save(tmp_path / "torques.csv")
    view = joint_space(LinkageTrajectory.load(tmp_path / "torques.csv"))
    path = view.save(tmp_path / "joints.csv")
    return path, path.with_name(path.name + ".meta.json")


#: the point-foot step with a double support: 0.05 s, on a ground of friction 1.5 (its plan
#: lifts the rear foot along its cone's edge: examples/feedback.md)
DOUBLE = "point feet, double support"


@pytest.fixture(scope="module", params=["point feet", "feet", DOUBLE])
def files(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp(request.param.replace(" ", "_").replace(",", ""))
    return _files(folder, request.param == "feet", 0.05 if request.param == DOUBLE else 0.0)


# ---- the robot, described again here from its numbers ---------------------------------------
def robot_mjcf(feet: bool, mu: float = 1.0) -> str:
    """The MJCF of the test robot: the torso floating in the sagittal plane, the URDF's joints
    and axes, and feet (the URDF's on feet; 0.5 kg soles at the shank's end on point feet),
    each touching the ground at a heel and a toe sphere."""
    table = {name: (l, m, n, j) for name, _, l, m, n, j in SIX_LINK_TABLE}
    torso, head = table["torso"], table["head"]
    thigh, shank = table["swing_thigh"], table["swing_shank"]

    def inertial(z, mass, iyy, x=0.0):
        inertia = f"{iyy!r} {iyy!r} {iyy!r}"
        return f'<inertial pos="{x!r} 0 {z!r}" mass="{mass!r}" diaginertia="{inertia}"/>'

    foot = FootGeometry()
    legs = []
    for side, (y, axis) in SIDES.items():
        if feet:
            com = FOOT_COM * foot.toe
            body = inertial(com.imag, foot.segment_mass, foot.inertia, com.real)
            marks = {"heel": foot.heel, "toe": foot.toe}
        else:
            body = inertial(0.0, POINT_FOOT_MASS, 0.002, 0.05)
            marks = {"heel": complex(-POINT_SOLE[0], 0.0), "toe": complex(POINT_SOLE[1], 0.0)}
        spheres = "".join(
            f'<geom name="{side}_{mark}" type="sphere" size="{SPHERE}" '
            f'pos="{p.real!r} 0 {p.imag + SPHERE!r}" contype="2" conaffinity="1" '
            f'condim="3" friction="{mu} 0.005 0.0001"/>'
            for mark, p in marks.items()
        )
        legs.append(
            f'<body name="{side}_thigh" pos="0 {y} 0">'
            f'<joint name="{side}_hip_pitch" axis="{axis}"/>'
            + inertial(-thigh[0] * thigh[2], thigh[1], thigh[3])
            + f'<body name="{side}_shank" pos="0 0 {-thigh[0]!r}">'
            f'<joint name="{side}_knee" axis="{axis}"/>'
            + inertial(-shank[0] * shank[2], shank[1], shank[3])
            + f'<body name="{side}_foot" pos="0 0 {-shank[0]!r}">'
            f'<joint name="{side}_ankle" axis="{axis}"/>{body}{spheres}'
            + "".join(
                f'<site name="{side}_{m}_site" pos="{p.real!r} 0 {p.imag!r}"/>'
                for m, p in marks.items()
            )
            + "</body></body></body>"
        )
    joints = [f"{side}_{j}" for side in SIDES for j in ("hip_pitch", "knee", "ankle")]
    motors = "".join(f'<motor name="{j}" joint="{j}"/>' for j in [*joints, "neck_pitch"])
    return (
        '<mujoco model="test_biped"><compiler angle="radian"/>'
        f'<option timestep="{TIMESTEP}" integrator="implicitfast" cone="elliptic"/>'
        '<default><geom contype="0" conaffinity="0"/><joint damping="0"/></default>'
        '<worldbody><geom name="ground" type="plane" size="0 0 1" contype="1" conaffinity="2" '
        f'condim="3" friction="{mu} 0.005 0.0001"/>'
        '<body name="torso" pos="0 0 1">'
        '<joint name="root_x" type="slide" axis="1 0 0"/>'
        '<joint name="root_z" type="slide" axis="0 0 1"/>'
        '<joint name="root_pitch" type="hinge" axis="0 1 0"/>'
        + inertial(torso[0] * torso[2], torso[1], torso[3])
        + f'<body name="head" pos="0 0 {torso[0]!r}"><joint name="neck_pitch" axis="0 -1 0"/>'
        + inertial(head[0] * head[2], head[1], head[3])
        + "</body>"
        + "".join(legs)
        + f"</body></worldbody><actuator>{motors}</actuator></mujoco>"
    )


# ---- the controller, from the files alone ------------------------------------------------------
class FileController:
    """joints.csv and its sidecar, read with numpy and json, run as the sidecar says."""

    def __init__(self, csv_path, meta_path, *, gains: bool = True):
        self.meta = json.loads(meta_path.read_text())
        table = np.genfromtxt(csv_path, delimiter=",", names=True)
        self.columns = {name: table[name] for name in table.dtype.names}
        spec = self.meta["controller"]
        assert spec["version"] == 1 and spec["gains"] is not None
        self.spec = spec
        self.state = spec["state"]
        self.drives = list(spec["drives"])
        self.limits = np.array([spec["drives"][d]["limit_N_m"] for d in self.drives])
        self.joints = {j["name"]: j for j in self.meta["joints"]}
        self.sides = self.meta["sides"]
        self.steps = self.meta["steps"]
        self.double = any(self.columns["double_support"] > 0)
        self.d0, self.d1 = spec["hip_ahead_m"]
        self.use_gains = gains
        # on point feet with a double support: its feedback waits out the soft touchdown
        self.settle = (spec.get("touchdown_settle_s", 0.0), spec.get("touchdown_ramp_s", 0.0))
        self.branches = {}
        for step in range(self.steps):
            for branch in (0, 1):
                rows = (self.columns["step"] == step) & (self.columns["double_support"] == branch)
                if not rows.any():
                    continue
                s = self.columns["phase"][rows]
                z = np.column_stack([self.columns[name][rows] for name in self.state])
                tau = np.column_stack([self.columns[spec["drives"][d]["torque"]][rows]
                                       for d in self.drives])  # fmt: skip
                K = np.stack([np.column_stack([self.columns[f"K_{d}__{x}"][rows]
                                               for x in self.state]) for d in self.drives],
                             axis=1)  # fmt: skip
                assert np.all(np.diff(s) > 0), "the phase rises along a branch"
                self.branches[(step, branch)] = (s, z, tau, K)

    def share(self, since_touchdown: float | None) -> float:
        """The part of the feedback applied ``since_touchdown`` s into a double support (None:
        in a single support): the sidecar's touchdown_settle_s, then touchdown_ramp_s."""
        settle, ramp = self.settle
        if since_touchdown is None or since_touchdown >= settle + ramp:
            return 1.0
        return 0.0 if since_touchdown < settle else (since_touchdown - settle) / ramp

    def law(self, step: int, branch: int, s: float, z: np.ndarray, share: float = 1.0):
        grid, Z, TAU, K = self.branches[(step % self.steps, branch)]
        if s <= grid[0]:  # before the first row: the first row
            z_ref, tau, gain = Z[0], TAU[0], K[0]
        elif s >= grid[-1]:  # past the last: z_ref on along its last slope, the rest held
            slope = (Z[-1] - Z[-2]) / (grid[-1] - grid[-2])
            z_ref, tau, gain = Z[-1] + (s - grid[-1]) * slope, TAU[-1], K[-1]
        else:
            k = int(np.searchsorted(grid, s, side="right") - 1)
            w = (s - grid[k]) / (grid[k + 1] - grid[k])
            z_ref = (1 - w) * Z[k] + w * Z[k + 1]
            tau = (1 - w) * TAU[k] + w * TAU[k + 1]
            gain = (1 - w) * K[k] + w * K[k + 1]
        if self.use_gains:
            tau = tau + share * (gain @ (z_ref - z))
        return np.clip(tau, -self.limits, self.limits)

    def first_row(self) -> dict:
        return {name: float(values[0]) for name, values in self.columns.items()}


class Walker:
    """The MuJoCo robot with its encoders: joint angles in the file's terms (each joint's
    URDF sign and zero from the sidecar; the point-foot robot's own ankles: sign -1 right, +1
    left, zero with the sole flat), its base pitch, its contact forces."""

    def __init__(self, controller: FileController, feet: bool, mass_scale: float = 1.0,
                 mu: float = 1.0):  # fmt: skip
        self.model = mujoco.MjModel.from_xml_string(robot_mjcf(feet, mu))
        self.model.geom_solref[:, 0] = 0.004
        if mass_scale != 1.0:
            self.model.body_mass[1:] *= mass_scale
            self.model.body_inertia[1:] *= mass_scale
        self.data = mujoco.MjData(self.model)
        self.c = controller
        self.feet = feet
        self.encoders = {}
        for drive in controller.drives:
            entry = controller.joints[drive]
            if entry.get("urdf_joint"):
                self.encoders[drive] = (entry["urdf_joint"], entry["urdf_sign"],
                                        entry["urdf_zero_rad"])  # fmt: skip
            else:  # the robot's own ankles on point feet
                side = drive.split("_")[0]
                self.encoders[drive] = (f"{side}_ankle", -1.0 if side == "right" else 1.0, 0.0)
        offset = controller.spec["robot"]["trunk_offset_rad"]
        self.pitch = ("root_pitch", 1.0, -offset)
        ground = self.model.geom("ground").id
        self.ground = ground
        self.foot_geoms = {side: {self.model.geom(f"{side}_{m}").id for m in ("heel", "toe")}
                           for side in SIDES}  # fmt: skip
        self.heels = {side: self.model.geom(f"{side}_heel").id for side in SIDES}

    def _addr(self, joint: str) -> tuple[int, int]:
        j = self.model.joint(joint)
        return int(j.qposadr[0]), int(j.dofadr[0])

    def read(self) -> np.ndarray:
        """z in the sidecar's state order."""
        values = {}
        for drive, (joint, sign, zero) in self.encoders.items():
            qa, va = self._addr(joint)
            name = self.c.joints[drive]["angle"]
            values[name] = (self.data.qpos[qa] - zero) * sign
            values["d" + name[:-3] + "rad_s"] = self.data.qvel[va] * sign
        qa, va = self._addr("root_pitch")
        values["trunk_pitch_rad"] = self.data.qpos[qa] - self.pitch[2]
        values["trunk_pitch_rate_rad_s"] = self.data.qvel[va]
        return np.array([values[name] for name in self.c.state])

    def command(self, tau: np.ndarray) -> None:
        for drive, value in zip(self.c.drives, tau, strict=True):
            joint, sign, _ = self.encoders[drive]
            self.data.ctrl[self.model.actuator(joint).id] = sign * value

    def start(self, row: dict, stance: str) -> None:
        """The file's first row: joints, pitch and rates; the stance sole on the ground (0.3
        mm into it) and at rest."""
        for drive, (joint, sign, zero) in self.encoders.items():
            qa, va = self._addr(joint)
            name = self.c.joints[drive]["angle"]
            self.data.qpos[qa] = sign * row[name] + zero
            self.data.qvel[va] = sign * row["d" + name[:-3] + "rad_s"]
        qa, va = self._addr("root_pitch")
        self.data.qpos[qa] = row["trunk_pitch_rad"] + self.pitch[2]
        self.data.qvel[va] = row["trunk_pitch_rate_rad_s"]
        mujoco.mj_kinematics(self.model, self.data)
        lowest = min(self.data.geom_xpos[g][2] for g in self.foot_geoms[stance]) - SPHERE
        self.data.qpos[self._addr("root_z")[0]] -= lowest + 3e-4
        mujoco.mj_forward(self.model, self.data)
        # the base's velocity that holds the stance toe at rest
        site = self.model.site(f"{stance}_toe_site").id
        jacp = np.zeros((3, self.model.nv))
        mujoco.mj_jacSite(self.model, self.data, jacp, None, site)
        vx, vz = self._addr("root_x")[1], self._addr("root_z")[1]
        rest = jacp @ self.data.qvel
        self.data.qvel[vx] -= rest[0]
        self.data.qvel[vz] -= rest[2]
        mujoco.mj_forward(self.model, self.data)

    def normal_force(self, side: str, heel_only: bool = False) -> float:
        geoms = {self.heels[side]} if heel_only else self.foot_geoms[side]
        total = 0.0
        force = np.zeros(6)
        for i in range(self.data.ncon):
            contact = self.data.contact[i]
            if {contact.geom1, contact.geom2} & geoms and self.ground in (
                contact.geom1,
                contact.geom2,
            ):
                mujoco.mj_contactForce(self.model, self.data, i, force)
                total += force[0]
        return total

    def phase(self, stance: str) -> float:
        """The sidecar's phase: the hip's distance ahead of the stance contact point (the toe
        mark on feet; the ankle, the plan's foot point, on point feet)."""
        hip = self.data.xpos[self.model.body("torso").id][0]
        if self.feet:
            contact = self.data.site_xpos[self.model.site(f"{stance}_toe_site").id][0]
        else:
            contact = self.data.xpos[self.model.body(f"{stance}_foot").id][0]
        return ((hip - contact) - self.c.d0) / (self.c.d1 - self.c.d0)

    def fallen(self) -> bool:
        heights = self.data.xpos[[self.model.body(n).id for n in ("torso", "head")], 2]
        knees = self.data.xpos[[self.model.body(f"{s}_shank").id for s in SIDES], 2]
        return bool(heights.min() < 0.5 or knees.min() < 0.1
                    or not np.all(np.isfinite(self.data.qpos)))  # fmt: skip


def walk(controller: FileController, feet: bool, steps: int = 20, **robot) -> tuple[int, str]:
    """(steps walked, why it stopped) under the files' law."""
    sides = controller.sides
    walker = Walker(controller, feet, **robot)
    walker.start(controller.first_row(), sides[0])
    substeps = round(1.0 / RATE_HZ / TIMESTEP)
    step_time = controller.meta["step_time_s"]
    step, branch, t_step, touched = 0, 0, 0.0, 0.0
    while step < steps:
        stance, swing = sides[step % 2], sides[(step + 1) % 2]
        s = walker.phase(stance)
        share = controller.share(t_step - touched if branch == 1 else None)
        walker.command(controller.law(step, branch, s, walker.read(), share))
        for _ in range(substeps):
            mujoco.mj_step(walker.model, walker.data)
        t_step += 1.0 / RATE_HZ
        if walker.fallen():
            return step, f"fell in step {step} at {t_step:.3f} s"
        if t_step > 2.0 * step_time:
            return step, f"no touchdown in step {step}"
        s = walker.phase(stance)
        if branch == 0 and s > 0.5 and walker.normal_force(swing, heel_only=feet) > 5.0:
            if controller.double:
                branch, touched = 1, t_step
            else:
                step, t_step = step + 1, 0.0
        elif branch == 1 and s >= 1.0:
            step, branch, t_step = step + 1, 0, 0.0
    return step, "walked"


def test_the_files_say_everything_the_controller_reads(files):
    csv_path, meta_path = files
    meta = json.loads(meta_path.read_text())
    spec = meta["controller"]
    keys = ("law", "state", "drives", "gains", "phase", "hip_ahead_m", "rows", "strike",
            "at_strike", "early_strike", "late", "before_start", "ankles", "rate_hz")  # fmt: skip
    for key in keys:
        assert spec[key], key
    header = csv_path.read_text().splitlines()[0].split(",")
    assert all(" " not in name for name in header)
    assert set(spec["state"]) <= set(header)
    for drive, entry in spec["drives"].items():
        assert entry["torque"] in header
        assert all(f"K_{drive}__{x}" in header for x in spec["state"])
    assert not [n for n in header if n.startswith("tau_") and "ground" in n]
    assert spec["rate_hz"] == RATE_HZ


def _ground(meta_path) -> dict:
    """The robot's ground: friction 1.5 under a point-foot double support's plan."""
    spec = json.loads(meta_path.read_text())["controller"]
    return {"mu": 1.5} if "touchdown_settle_s" in spec else {}


def test_a_controller_from_the_files_alone_walks_twenty_steps(files):
    csv_path, meta_path = files
    feet = json.loads(meta_path.read_text())["feet"] != "points"
    walked, why = walk(FileController(csv_path, meta_path), feet, **_ground(meta_path))
    assert walked == 20, why
    if _ground(meta_path):  # a point-foot double support: the sidecar's touchdown rule matters
        ignoring = FileController(csv_path, meta_path)
        ignoring.settle = (0.0, 0.0)  # its feedback at once, as on a rigid ground
        walked, why = walk(ignoring, feet, **_ground(meta_path))
        assert walked < 20, why


def test_heavier_and_without_the_gains(files):
    """10 % heavier it still walks; the feedforward torques alone (rows and swaps right, the
    gains left out) fall: the walk depends on the law the file states."""
    csv_path, meta_path = files
    feet = json.loads(meta_path.read_text())["feet"] != "points"
    ground = _ground(meta_path)
    walked, why = walk(FileController(csv_path, meta_path), feet, mass_scale=1.1, **ground)
    assert walked == 20, why
    walked, why = walk(FileController(csv_path, meta_path, gains=False), feet, steps=20,
                       **ground)  # fmt: skip
    assert walked < 20, why


def test_the_files_law_is_the_plans_law_in_joint_coordinates(files):
    """At perturbed states of the model (psi, dpsi), the drives' torques of the model file's
    law (M = M_ff + K (x_ref - x), turned into drives by the physical hips' sums) equal the
    joint-space file's law at the same state, read as a robot reads it (joint angles of the
    perturbed links by problems.human.joints, the trunk's pitch, the level swing sole)."""
    csv_path, meta_path = files
    model = LinkageTrajectory.load(csv_path.with_name("torques.csv"))
    controller = FileController(csv_path, meta_path)
    linkage = Linkage.from_parameters(model.metadata["model"])
    names, n = linkage.names, linkage.n
    body = body_of(linkage, model.metadata["gait"].get("neutral_ankles"))
    states = [f"psi_{x}" for x in names] + [f"dpsi_{x}" for x in names]
    gains = np.stack([np.column_stack([np.asarray(model.column(f"K_{h}__{x}")) for x in states])
                      for h in names], axis=1)  # fmt: skip
    sides = {"stance": controller.sides[0], "swing": controller.sides[1]}
    trunk, head = names.index(body.trunk), names.index("head")
    rng = np.random.default_rng(2)
    worst = 0.0
    for k in rng.choice(np.flatnonzero(controller.columns["step"] == 0), 8, replace=False):
        psi = model.psi[k] + rng.normal(0.0, 0.05, n)
        dpsi = model.dpsi[k] + rng.normal(0.0, 0.3, n)
        M = model.torques[k] + gains[k] @ (np.r_[model.psi[k], model.dpsi[k]] - np.r_[psi, dpsi])
        hinge = dict(zip(names, M, strict=True))
        expected, z = {"neck": M[head]}, {}
        for role, leg in (("stance", body.stance), ("swing", body.swing)):
            moments = leg_moments(body, leg, hinge, 1.0)
            for joint in ("hip", "knee", "ankle"):
                if moments[f"{joint}_moment"] is not None:
                    expected[f"{sides[role]}_{joint}"] = -moments[f"{joint}_moment"]
            for prefix, values in (("q", psi), ("dq", dpsi)):
                angles = joint_radians(body, leg, dict(zip(names, values, strict=True)))
                zero = joint_radians(body, leg, dict(zip(names, np.zeros(n), strict=True)))
                for joint, value in angles.items():
                    if joint == "thigh":
                        continue
                    if value is None:  # a point foot's swing sole, level
                        shank = names.index(leg.shank)
                        value = -np.pi / 2 - values[shank] if prefix == "q" else -values[shank]
                    elif prefix == "dq":
                        value = value - zero[joint]
                    suffix = "rad" if prefix == "q" else "rad_s"
                    z[f"{prefix}_{sides[role]}_{joint}_{suffix}"] = value
        z["q_neck_rad"], z["dq_neck_rad_s"] = psi[head] - psi[trunk], dpsi[head] - dpsi[trunk]
        z["trunk_pitch_rad"], z["trunk_pitch_rate_rad_s"] = np.pi / 2 - psi[trunk], -dpsi[trunk]
        controller.limits = np.full(len(controller.drives), np.inf)
        branch = int(controller.columns["double_support"][k])
        tau = controller.law(0, branch, controller.columns["phase"][k],
                             np.array([z[x] for x in controller.state]))  # fmt: skip
        for drive, value in expected.items():
            worst = max(worst, abs(tau[controller.drives.index(drive)] - value))
    assert worst < 1e-8
