"""MuJoCo backend of :class:`sim.scene.Backend`, model built with ``mujoco.MjSpec``.

The scene plane is MuJoCo's x-y plane (z out of the plane). Settings that make MuJoCo resolve
stick/slip (docs/simulation-measurements.md, "Engine facts"): elliptic friction cone,
``noslip_iterations = 20``, ``noslip_tolerance = 1e-12``, explicit ``<pair condim=3>`` per contact
pair (all other collisions disabled, pair friction changed between steps through
``model.pair_friction``), and one extra out-of-plane slide degree of freedom on every dynamic body
(noslip does nothing in a strictly planar model).


* Polygons become thin boxes along their edges, cut back at acute vertices whose tips are
  triangular prisms (:mod:`sim.backends.mujoco_polygon`: nothing sticks out of the polygon),
  ``0.2 * length_scale`` thick out of the plane; circles spheres in the plane, segments
  capsules.
* Dynamic body: slide x, slide y, slide z, hinge z at the body origin; explicit mass, COM and
  inertia.
* Driven body: slide x, slide y, hinge z, mass ``heavy_ratio`` (default :data:`HEAVY_RATIO`)
  times the heaviest dynamic body, with ``qpos``/``qvel`` overwritten before every step (mocap
  bodies do not transmit friction).
* Joint to the base: hinge z (revolute) or slide along ``axis`` (prismatic) at ``anchor``; a
  joint on a parent body (a chain link): the body nested in its parent, same joint types;
  velocity-controlled joints get a huge armature and their ``qpos``/``qvel`` overwritten every step;
  effort-controlled joints get the effort in ``qfrc_applied``.
* Loads: ``xfrc_applied`` (force at the body COM and a torque about z).
* Contact impedance per pair role (:mod:`sim.backends.roles`, decided after the first
  ``mj_forward``): ``squeeze`` pairs keep ``solref``/``solimp`` (with ``squeeze_d0`` set:
  ``solimp = (squeeze_d0, solimp[0], load width)``, :mod:`sim.backends.mujoco_impedance`, and
  ``squeeze_solref``), ``support`` pairs get ``support_solimp`` and ``support_solref``,
  ``carry`` pairs ``carry_solref``; a scene without ``squeeze`` pairs gets ``carry_impratio``,
  else one with ``support`` pairs ``support_impratio`` (:mod:`sim.backends.mujoco_impedance`).

Forces are read with ``mj_contactForce`` in the contact frame and projected to the world;
velocities of contact points with ``mj_jac``.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from sim.backends.mujoco_impedance import apply_role_impedance, creep_impratio, scene_load
from sim.backends.mujoco_polygon import polygon_geoms
from sim.backends.roles import contact_roles
from sim.backends.switching import replace_joint, switch_joint
from sim.scene import (
    ABSENT,
    BodyKind,
    BodyState,
    Capsule,
    Circle,
    ContactReading,
    Control,
    JointKind,
    Polygon,
    Scene,
)
from sim.settings import CARRY_IMPRATIO, CARRY_SOLREF, HEAVY_RATIO, SUPPORT_SOLIMP


class MujocoBackend:
    """MuJoCo (mujoco-core) via MjSpec."""

    name = "mujoco"

    def __init__(self, noslip_iterations: int = 20,
                 solref: tuple[float, float] = (0.004, 1.0),
                 solimp: tuple[float, ...] = (0.99, 0.999, 0.001, 0.5, 2.0),
                 impratio: float = 1.0, out_of_plane_stiffness: float = 0.0,
                 support_solimp: tuple[float, ...] | None = SUPPORT_SOLIMP,
                 carry_solref: tuple[float, float] | None = CARRY_SOLREF,
                 carry_impratio: float = CARRY_IMPRATIO,
                 squeeze_d0: float | None = None,
                 squeeze_solref: tuple[float, float] | None = None,
                 heavy_ratio: float = HEAVY_RATIO,
                 support_solref: tuple[float, float] | None = None,
                 support_impratio: float | None = None,
                 contact_force: float | None = None,
                 stick_speed: float | None = None) -> None:
        self.impratio = impratio
        #: a contact holding its friction times ``contact_force`` [N] creeps slower than
        #: ``stick_speed`` [m/s] (:func:`sim.backends.mujoco_impedance.creep_impratio`)
        self.contact_force, self.stick_speed = contact_force, stick_speed
        #: the impratio the built model runs with (the roles' or the creep bound's)
        self.impratio_used = impratio
        #: driven-body mass over the heaviest dynamic body's (:data:`HEAVY_RATIO`)
        self.heavy_ratio = heavy_ratio
        #: solimp d0 of every ``squeeze`` pair, rising to ``solimp[0]`` (the stiff default) over
        #: the load width (:mod:`sim.backends.mujoco_impedance`); ``None``: ``solimp`` unchanged
        self.squeeze_d0 = squeeze_d0
        #: solref of the ``squeeze`` pairs that get ``squeeze_d0``; ``None``: ``solref``
        self.squeeze_solref = squeeze_solref
        #: ``{pair: solimp width [m]}`` given to the ``squeeze`` pairs (the load width)
        self.squeeze_widths: dict[str, float] = {}
        #: solimp, solref of every ``support`` pair (a static body: a table, a palm) and the
        #: impratio of a scene with them; ``None`` keeps ``solimp``, ``solref``, ``impratio``
        self.support_solimp = support_solimp
        self.support_solref, self.support_impratio = support_solref, support_impratio
        #: solref of every ``carry`` pair and impratio of a scene without ``squeeze`` pairs
        #: (:mod:`sim.backends.roles`); ``None``: ``solref``
        self.carry_solref = carry_solref
        self.carry_impratio = carry_impratio
        #: ``{pair: role}`` of the built scene
        self.roles: dict[str, str] = {}
        #: spring [N/m] (critically damped) holding dynamic bodies' out-of-plane slide at z = 0:
        #: a sphere touching a capsule is unstable out of the plane when friction is ~0.
        self.out_of_plane_stiffness = out_of_plane_stiffness
        self.noslip_iterations = noslip_iterations
        self.solref = solref
        self.solimp = solimp
        self.t = 0.0

    # -- construction ------------------------------------------------------------------
    def build(self, scene: Scene) -> None:
        self.scene = scene
        spec = mujoco.MjSpec()
        spec.option.gravity = [0.0, 0.0, 0.0]
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.noslip_iterations = self.noslip_iterations
        spec.option.noslip_tolerance = 1e-12
        spec.option.impratio = self.impratio
        spec.option.ccd_tolerance = 1e-12
        spec.option.ccd_iterations = 200
        spec.option.timestep = 0.002
        depth = 0.1 * scene.length_scale
        heavy = self._heavy_mass(scene)
        joints_of = {j.body: j for j in scene.joints}
        self._geoms: dict[tuple[str, int], list[str]] = {}
        self._dofs: dict[str, list[str]] = {}
        created: dict[str, Any] = {}
        for b in scene.bodies:
            x, y, th = b.pose
            if b.kind == BodyKind.STATIC:
                body = spec.worldbody.add_body(name=b.name, pos=[x, y, 0.0],
                                               quat=[np.cos(th / 2), 0, 0, np.sin(th / 2)])
            else:
                host, (rx, ry, rth) = self._chain_host(spec, scene, b.name, created)
                body = host.add_body(name=b.name, pos=[rx, ry, 0.0],
                                     quat=[np.cos(rth / 2), 0, 0, np.sin(rth / 2)])
                mass = heavy if b.kind == BodyKind.DRIVEN else b.mass
                izz = b.inertia if b.inertia is not None else mass * scene.length_scale ** 2 / 6
                if b.kind == BodyKind.DRIVEN:
                    izz = heavy * scene.length_scale ** 2
                body.explicitinertial = True
                body.mass = mass
                body.ipos = [b.com[0], b.com[1], 0.0]
                body.inertia = [izz, izz, izz]
                names = []
                if b.name in joints_of:
                    j = joints_of[b.name]
                    # joint position in the body frame
                    c, s = np.cos(th), np.sin(th)
                    d = np.array(j.anchor) - np.array([x, y])
                    local = [c * d[0] + s * d[1], -s * d[0] + c * d[1], 0.0]
                    if j.kind == JointKind.REVOLUTE:
                        jt, axis = mujoco.mjtJoint.mjJNT_HINGE, [0, 0, 1]
                    else:
                        ax = np.asarray(j.axis, dtype=float)
                        jt, axis = mujoco.mjtJoint.mjJNT_SLIDE, [c * ax[0] + s * ax[1],
                                                                -s * ax[0] + c * ax[1], 0]
                    jn = body.add_joint(name=f"{b.name}:{j.name}", type=jt, axis=axis, pos=local)
                    if j.control == Control.VELOCITY:
                        jn.armature = heavy * scene.length_scale ** 2
                    names.append(f"{b.name}:{j.name}")
                else:
                    axes = [("x", mujoco.mjtJoint.mjJNT_SLIDE, [1, 0, 0]),
                            ("y", mujoco.mjtJoint.mjJNT_SLIDE, [0, 1, 0])]
                    if b.kind == BodyKind.DYNAMIC:
                        axes.append(("z", mujoco.mjtJoint.mjJNT_SLIDE, [0, 0, 1]))
                    axes.append(("rz", mujoco.mjtJoint.mjJNT_HINGE, [0, 0, 1]))
                    for suffix, jt, axis in axes:
                        jn = body.add_joint(name=f"{b.name}:{suffix}", type=jt, axis=axis)
                        if suffix == "z" and self.out_of_plane_stiffness > 0:
                            k = self.out_of_plane_stiffness
                            jn.stiffness = [k, 0.0, 0.0]
                            jn.damping = [2.0 * np.sqrt(k * mass), 0.0, 0.0]
                        names.append(f"{b.name}:{suffix}")
                self._dofs[b.name] = names
            created[b.name] = body
            for k, shp in enumerate(b.shapes):
                gname = f"{b.name}:g{k}"
                if isinstance(shp, Polygon):
                    geoms = polygon_geoms(spec, body, gname, np.asarray(shp.vertices, dtype=float),
                                          depth, scene.length_scale)
                    self._geoms[(b.name, k)] = [g.name for g in geoms]
                    continue
                elif isinstance(shp, Circle):
                    geom = body.add_geom(name=gname, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                                         size=[shp.radius, 0, 0],
                                         pos=[shp.center[0], shp.center[1], 0.0])
                elif isinstance(shp, Capsule):
                    geom = body.add_geom(name=gname, type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                                         size=[shp.radius, 0, 0],
                                         fromto=[shp.a[0], shp.a[1], 0, shp.b[0], shp.b[1], 0])
                else:  # pragma: no cover
                    raise TypeError(type(shp))
                geom.contype = 0
                geom.conaffinity = 0
                geom.mass = 0.0
                self._geoms[(b.name, k)] = [gname]
        self._subpairs: dict[str, list[int]] = {}
        n_sub = 0
        for p in scene.pairs:
            self._subpairs[p.name] = []
            for ga in self._geoms[(p.body_a, p.shape_a)]:
                for gb in self._geoms[(p.body_b, p.shape_b)]:
                    spec.add_pair(name=f"{p.name}#{n_sub}", geomname1=ga, geomname2=gb,
                                  condim=3,
                                  friction=[p.mu_static, p.mu_static, 0.005, 1e-4, 1e-4],
                                  solref=list(self.solref), solimp=list(self.solimp))
                    self._subpairs[p.name].append(n_sub)
                    n_sub += 1
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        # the compiler sorts pairs (by body signature), so a pair's index in the model is not
        # the order it was added in: look every sub-pair up by name
        self._subpairs = {name: [int(m.pair(f"{name}#{k}").id) for k in ks]
                          for name, ks in self._subpairs.items()}
        self._qadr = {nm: int(m.jnt_qposadr[m.joint(nm).id]) for v in self._dofs.values()
                      for nm in v}
        self._vadr = {nm: int(m.jnt_dofadr[m.joint(nm).id]) for v in self._dofs.values()
                      for nm in v}
        self._body_id = {b.name: m.body(b.name).id for b in scene.bodies}
        self._pair_id = {p.name: i for i, p in enumerate(scene.pairs)}
        self._geom_pair = {}
        for p in scene.pairs:
            for na in self._geoms[(p.body_a, p.shape_a)]:
                for nb in self._geoms[(p.body_b, p.shape_b)]:
                    ga, gb = m.geom(na).id, m.geom(nb).id
                    self._geom_pair[(ga, gb)] = (p.name, 1.0)
                    self._geom_pair[(gb, ga)] = (p.name, -1.0)
        self._target = {nm: float(self.data.qpos[a]) for nm, a in self._qadr.items()}
        mujoco.mj_forward(m, self.data)
        self._set_roles()
        self._readings: dict[str, ContactReading] = {}

    # -- chains: a link body nested in its parent link --------------------------------
    @staticmethod
    def _chain_host(spec: Any, scene: Scene, name: str, created: dict[str, Any]
                    ) -> tuple[Any, tuple[float, float, float]]:
        """Where to attach body ``name``: the MjSpec body of its joint's parent (a chain link
        nests in the previous link, so MuJoCo's joint acts between the two) and its pose
        relative to that parent; the world body and its world pose otherwise."""
        joint = next((j for j in scene.joints if j.body == name), None)
        x, y, th = scene.body(name).pose
        if joint is None or joint.parent is None:
            return spec.worldbody, (x, y, th)
        px, py, pth = scene.body(joint.parent).pose
        c, s = np.cos(pth), np.sin(pth)
        dx, dy = x - px, y - py
        return created[joint.parent], (c * dx + s * dy, -s * dx + c * dy, th - pth)

    def _set_roles(self) -> None:
        """Decide every pair's role (:mod:`sim.backends.roles`) and set its contact impedance
        (:func:`sim.backends.mujoco_impedance.apply_role_impedance`)."""
        self.roles = contact_roles(self.scene, self._read_contacts(), self.state())
        self.squeeze_widths = apply_role_impedance(self.model, self.data, self.roles,
                                                   self._subpairs, scene_load(self.scene), self)
        mujoco.mj_forward(self.model, self.data)
        if self.contact_force is not None and self.stick_speed is not None:
            need = creep_impratio(self.model, self.data, self._subpairs, self.contact_force,
                                  self.stick_speed)
            if need > self.model.opt.impratio:
                self.model.opt.impratio = need
                mujoco.mj_forward(self.model, self.data)
        self.impratio_used = float(self.model.opt.impratio)

    def _heavy_mass(self, scene: Scene) -> float:
        """Mass [kg] of a driven body (armature of a velocity-controlled joint per length
        scale squared): ``heavy_ratio`` times the heaviest dynamic body's (1 kg without one)."""
        return self.heavy_ratio * max([b.mass for b in scene.bodies
                                       if b.kind == BodyKind.DYNAMIC] or [1.0])

    # -- stepping ----------------------------------------------------------------------
    def _drive(self, joint: str, velocity: float, dt: float) -> None:
        self._target[joint] += velocity * dt
        self.data.qpos[self._qadr[joint]] = self._target[joint] - velocity * dt
        self.data.qvel[self._vadr[joint]] = velocity

    def step(self, dt: float) -> None:
        m, d = self.model, self.data
        m.opt.timestep = dt
        states = self.state()
        d.qfrc_applied[:] = 0.0
        d.xfrc_applied[:] = 0.0
        for b in self.scene.bodies:
            if b.kind == BodyKind.DRIVEN and b.twist is not None and b.name not in {
                    j.body for j in self.scene.joints}:
                tw = [float(v) for v in b.twist(self.t, states)]
                for nm, v in zip(self._dofs[b.name], tw):
                    self._drive(nm, v, dt)
        for j in self.scene.joints:
            u = float(j.command(self.t, states))
            nm = f"{j.body}:{j.name}"
            if j.control == Control.VELOCITY:
                self._drive(nm, u, dt)
            else:
                d.qfrc_applied[self._vadr[nm]] += u
        for ld in self.scene.loads:
            bid = self._body_id[ld.body]
            d.xfrc_applied[bid, 0:2] += ld.force
            d.xfrc_applied[bid, 5] += ld.moment
        mujoco.mj_step(m, d)
        self.t += dt
        self._readings = self._read_contacts()

    # -- readout -----------------------------------------------------------------------
    def _point_velocity(self, body: str, point: np.ndarray) -> np.ndarray:
        jacp = np.zeros((3, self.model.nv))
        mujoco.mj_jac(self.model, self.data, jacp, None, np.array([point[0], point[1], 0.0]),
                      self._body_id[body])
        return (jacp @ self.data.qvel)[:2]

    def _read_contacts(self) -> dict[str, ContactReading]:
        """One reading per pair. Several MuJoCo contacts of one pair (a vertex touching two
        edge boxes, a flat edge on a surface) are summed: the pair's force is the sum of their
        forces, its normal the deepest contact's, its point the normal-force-weighted mean
        point (the deepest one when no force), its depth the largest."""
        m, d = self.model, self.data
        parts: dict[str, list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]] = {}
        f6 = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            key = (int(con.geom[0]), int(con.geom[1]))
            if key not in self._geom_pair:
                continue
            name, sign = self._geom_pair[key]
            mujoco.mj_contactForce(m, d, i, f6)
            frame = np.asarray(con.frame).reshape(3, 3)
            n3 = sign * frame[0]
            n = n3[:2] / max(np.linalg.norm(n3[:2]), 1e-300)
            f_world = f6[0] * frame[0] + f6[1] * frame[1] + f6[2] * frame[2]
            f = f_world[:2]
            if float(f @ n) < 0:
                f = -f
            parts.setdefault(name, []).append(
                (float(-con.dist), np.asarray(con.pos[:2], dtype=float), n, f))
        out: dict[str, ContactReading] = {}
        for name, items in parts.items():
            pair = self.scene.pairs[self._pair_id[name]]
            depth, point, n, _ = max(items, key=lambda it: it[0])
            t = np.array([-n[1], n[0]])
            f = np.sum([it[3] for it in items], axis=0)
            w = np.array([max(float(it[3] @ n), 0.0) for it in items])
            if len(items) > 1 and w.sum() > 0:
                point = np.sum([wi * it[1] for wi, it in zip(w, items)], axis=0) / w.sum()
            va = self._point_velocity(pair.body_a, point)
            vb = self._point_velocity(pair.body_b, point)
            out[name] = ContactReading(
                present=True,
                point=(float(point[0]), float(point[1])),
                normal=(float(n[0]), float(n[1])),
                normal_force=float(f @ n),
                tangent_force=float(f @ t),
                slip_velocity=float((vb - va) @ t),
                depth=depth,
            )
        return out

    def state(self) -> dict[str, BodyState]:
        out = {}
        for b in self.scene.bodies:
            bid = self._body_id[b.name]
            pos = np.array(self.data.xpos[bid])
            mat = np.asarray(self.data.xmat[bid]).reshape(3, 3)
            theta = float(np.arctan2(mat[1, 0], mat[0, 0]))
            if b.kind == BodyKind.STATIC:
                v, w = np.zeros(2), 0.0
            else:
                v = self._point_velocity(b.name, pos[:2])
                jacr = np.zeros((3, self.model.nv))
                mujoco.mj_jacBody(self.model, self.data, None, jacr, bid)
                w = float((jacr @ self.data.qvel)[2])
            out[b.name] = BodyState(pose=(float(pos[0]), float(pos[1]), theta),
                                    twist=(float(v[0]), float(v[1]), w))
        return out

    def health(self) -> str | None:
        """A reason when MuJoCo flagged numerical trouble (it silently resets the state on a
        bad acceleration, so NaN never reaches :meth:`state`)."""
        w = self.data.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)]
        if w.number > 0:
            return f"MuJoCo: NaN/Inf/huge acceleration (mjWARN_BADQACC) at DOF {w.lastinfo}"
        return None

    def contacts(self) -> dict[str, ContactReading]:
        return {p.name: self._readings.get(p.name, ABSENT) for p in self.scene.pairs}

    def set_friction(self, pair: str, mu: float) -> None:
        for i in self._subpairs[pair]:
            self.model.pair_friction[i, 0] = mu
            self.model.pair_friction[i, 1] = mu

    # -- control switching (a whole task: segments with other control partitions) ----------
    def set_control(self, joint: str, control: Control | str) -> None:
        """Switch revolute joint ``joint`` to ``control`` from the next step on: velocity
        control gives its degree of freedom the heavy armature and the ``qpos``/``qvel``
        override (the target starts at the joint's present position), effort control takes
        both away (armature 0; the command goes to ``qfrc_applied``)."""
        j = switch_joint(self.scene, joint, control)
        if j is None:
            return
        nm = f"{j.body}:{j.name}"
        if control == Control.VELOCITY:
            self.model.dof_armature[self._vadr[nm]] = (self._heavy_mass(self.scene)
                                                       * self.scene.length_scale ** 2)
            self._target[nm] = float(self.data.qpos[self._qadr[nm]])
        else:
            self.model.dof_armature[self._vadr[nm]] = 0.0
        self.scene = replace_joint(self.scene, j, control)

