"""DART (``dartpy``) backend of :class:`sim.scene.Backend`: a complementarity referee.

Each step DART solves the contacts and joints as one constraint problem, here with its
non-smooth Gauss-Seidel solver under the exact Coulomb law (:data:`NSGS_TOLERANCE`; DART's
default Dantzig pivoting bounds friction by the *frictionless* normal impulses, which left the
sliding fingers of a squeeze at 0.6-0.8 mu). Facts and derivations: docs/engine-dart.md.

The scene plane is DART's x-y plane; shapes are extruded symmetrically about z = 0.

* dynamic body: ``PlanarJoint`` (x, y, theta) on a light carrier sliding along z
  (:data:`CARRIER_MASS_RATIO`; without it every contact's z friction row is zero and the
  problem singular); driven body: ``PlanarJoint`` with the ``VELOCITY`` actuator (moves at the
  commanded twist, unmoved by contacts, transmits friction); static body: welded to the world;
* joint: ``RevoluteJoint`` (z) or ``PrismaticJoint`` at the anchor, on the carrier (to the
  base) or on the parent link (chains); ``VELOCITY`` actuator (exact rate, unbounded effort) or
  ``FORCE`` actuator (effort on the body and, opposite, on the parent); loads: external force at
  the centre of mass and torque about z, every step;
* contacts: per pair, side and kind of primitive (:func:`sim.backends.dart_shapes.primitives`)
  a massless *site* body welded to the pair's body, and a body-pair filter letting a site touch
  only its partner's sites of a colliding kind -- only declared pairs collide, each with its own
  Coulomb coefficient, and every contact is a sphere against a box or sphere in the plane z = 0.

Fixed engine options (docs/engine-dart.md): gravity 0 (loads are explicit), sleeping off (DART
freezes bodies slower than 1 cm/s for 0.5 s), split impulses, DART's collision detector, the
depth floor :data:`DEPTH_FLOOR_OF_SCALE`.
"""

from __future__ import annotations

from collections.abc import Sequence

import dartpy as dart
import numpy as np

from planner.errors import InputError
from sim.backends.dart_shapes import (
    COLLIDING,
    moment_of_inertia,
    primitives,
    rotation,
)
from sim.backends.switching import replace_joint, switch_joint
from sim.scene import (
    ABSENT,
    Body,
    BodyKind,
    BodyState,
    ContactReading,
    Control,
    Joint,
    JointKind,
    Scene,
    point_velocity,
)

#: Mass of a z carrier and of a contact site over the scene's heaviest dynamic body (they only
#: keep the LCP regular; their inertia is negligible at this ratio).
CARRIER_MASS_RATIO = 1e-6
#: Depth floor of a touching contact, in scene length scales: DART pushes a contact out by 1 % of
#: its depth per step (compiled in), so a resting depth decays until rounding drops the contact
#: for a step (the ruler then chattered); a shallower contact has its sphere grown to the floor
#: (:attr:`DartBackend.inflation` sums the growth, ~0.01 floor per contact-step at rest).
DEPTH_FLOOR_OF_SCALE = 1e-8
#: Residual (DART's measure, ~ the worst contact's velocity error [m/s]) and sweep cap of the
#: Coulomb solve: 1e-5 of the slowest drive (1e-4 m/s), below the :data:`CFM` creep; a jam has
#: no solution and stops at the cap (:attr:`DartBackend.unconverged` counts those solves). The
#: cap is a budget, not a threshold: a solve that reaches the tolerance stops there whatever the
#: cap. Gauss-Seidel needs more sweeps the larger the contact forces are against the load (a
#: workpiece close to a jam, whose forces grow without bound at the jam's friction): Example 4.1
#: at forces 30-40x its load converges in 500-5,000 sweeps; capped at 500 it returned a solution
#: that was none (the finger read as sticking, forces 1/15 of the certificate's) on half the
#: solves. docs/engine-dart.md, "The sweep cap": what it changed and what it costs.
NSGS_TOLERANCE = 1e-9
NSGS_MAX_SWEEPS = 5000
#: DART's constraint force mixing (compiled in): a sticking contact slips at about
#: ``CFM x |tangential impulse| x inverse effective mass`` -- the creep floor.
CFM = 1e-5


def _iso(rot: np.ndarray, p: Sequence[float]) -> dart.math.Isometry3:
    tf = dart.math.Isometry3()
    tf.set_rotation(rot)
    tf.set_translation([float(p[0]), float(p[1]), float(p[2]) if len(p) > 2 else 0.0])
    return tf


class DartBackend:
    """DART via dartpy (module docstring). No options: every setting is derived from the scene
    (the run's time step, speed and creep floor are the settings table's,
    :data:`sim.settings.SETTINGS`)."""

    name = "dart"

    def __init__(self) -> None:
        self.t = 0.0

    # -- construction ------------------------------------------------------------------
    def build(self, scene: Scene) -> None:
        self.scene = scene
        world = dart.simulation.World()
        world.setGravity([0.0, 0.0, 0.0])
        sleep = world.getDeactivationOptions()
        sleep.mEnabled = False  # DART's default freezes bodies slower than 1 cm/s
        world.setDeactivationOptions(sleep)
        world.setCollisionDetector(dart.simulation.CollisionDetectorType.DART)
        solver = world.getConstraintSolver()
        solver.setSplitImpulseEnabled(True)
        options = dart.constraint.NsgsFrictionSolver.Options()
        options.law = dart.constraint.NsgsFrictionSolver.Law.Coulomb
        options.tolerance = NSGS_TOLERANCE
        options.maxSweeps = NSGS_MAX_SWEEPS
        self._solver = dart.constraint.NsgsFrictionSolver(options)
        solver.setBoxedLcpSolver(self._solver)
        self.world = world
        self._light = CARRIER_MASS_RATIO * max(
            [b.mass for b in scene.bodies if b.kind == BodyKind.DYNAMIC] or [1.0])
        joint_of = {j.body: j for j in scene.joints}
        self.nodes: dict[str, dart.dynamics.BodyNode] = {}
        self.joints: dict[str, dart.dynamics.Joint] = {}
        self._skeletons: list[dart.dynamics.Skeleton] = []
        for b in scene.bodies:
            j = joint_of.get(b.name)
            if b.kind == BodyKind.STATIC:
                if j is not None:
                    raise InputError(f"joint {j.name!r}: expected a joint on a dynamic or "
                                     f"driven body, got static body {b.name!r}")
                self.nodes[b.name] = self._static(b)
            elif j is not None and j.parent is not None and \
                    scene.body(j.parent).kind != BodyKind.STATIC:
                self.nodes[b.name] = self._jointed(b, j, self.nodes[j.parent])
            elif j is not None:
                self.nodes[b.name] = self._jointed(b, j, self._carrier(b.name))
            elif b.kind == BodyKind.DRIVEN:
                self.nodes[b.name] = self._planar(b, None, driven=True)
            else:
                self.nodes[b.name] = self._planar(b, self._carrier(b.name), driven=False)
        self._build_sites(scene)
        for skel in self._skeletons:
            world.addSkeleton(skel)
        self._readings: dict[str, ContactReading] = {}
        self._states: dict[str, BodyState] | None = None

    def _skeleton(self, name: str) -> dart.dynamics.Skeleton:
        self._skeletons.append(dart.dynamics.Skeleton(name))
        return self._skeletons[-1]

    def _static(self, b: Body) -> dart.dynamics.BodyNode:
        skel = self._skeleton(b.name)
        joint, node = skel.createWeldJointAndBodyNodePair(None)
        joint.setTransformFromParentBodyNode(_iso(rotation(b.pose[2]), b.pose[:2]))
        skel.setMobile(False)
        return node

    def _carrier(self, name: str) -> dart.dynamics.BodyNode:
        """Root of a mobile skeleton: a light body sliding along z (module docstring)."""
        joint, node = self._skeleton(name).createPrismaticJointAndBodyNodePair(None)
        joint.setAxis([0.0, 0.0, 1.0])
        self._mass(node, self._light, self._light)
        return node

    def _mass(self, node: dart.dynamics.BodyNode, mass: float, inertia: float,
              com: Sequence[float] = (0.0, 0.0)) -> None:
        node.setMass(float(mass))
        node.setLocalCOM([float(com[0]), float(com[1]), 0.0])
        node.setMomentOfInertia(inertia, inertia, inertia)

    def _planar(self, b: Body, parent: dart.dynamics.BodyNode | None,
                driven: bool) -> dart.dynamics.BodyNode:
        skel = parent.getSkeleton() if parent is not None else self._skeleton(b.name)
        joint, node = skel.createPlanarJointAndBodyNodePair(parent)
        joint.setXYPlane()
        joint.setPositions(np.asarray(b.pose, dtype=float))
        if driven:
            joint.setActuatorType(dart.dynamics.ActuatorType.VELOCITY)
            self._mass(node, 1.0, 1.0)
        else:
            self._mass(node, b.mass, moment_of_inertia(b), b.com)
        return node

    def _jointed(self, b: Body, j: Joint, parent: dart.dynamics.BodyNode
                 ) -> dart.dynamics.BodyNode:
        """Body ``b`` on revolute/prismatic joint ``j`` to ``parent`` (a chain link or the
        carrier of a joint to the base). Joint frame: at the anchor, oriented like ``b`` at
        its initial pose, so the joint coordinate is 0 at the scene's poses."""
        skel = parent.getSkeleton()
        if j.kind == JointKind.REVOLUTE:
            joint, node = skel.createRevoluteJointAndBodyNodePair(parent)
            joint.setAxis([0.0, 0.0, 1.0])
        else:
            joint, node = skel.createPrismaticJointAndBodyNodePair(parent)
            ax = rotation(b.pose[2])[:2, :2].T @ np.asarray(j.axis, dtype=float)
            joint.setAxis([float(ax[0]), float(ax[1]), 0.0])
        pp = (self.scene.body(j.parent).pose if j.parent is not None
              and self.scene.body(j.parent).kind != BodyKind.STATIC else (0.0, 0.0, 0.0))
        rp, rb = rotation(pp[2]), rotation(b.pose[2])
        anchor = np.array([j.anchor[0], j.anchor[1], 0.0])
        joint.setTransformFromParentBodyNode(
            _iso(rp.T @ rb, rp.T @ (anchor - np.array([pp[0], pp[1], 0.0]))))
        joint.setTransformFromChildBodyNode(
            _iso(np.eye(3), rb.T @ (anchor - np.array([b.pose[0], b.pose[1], 0.0]))))
        self._mass(node, b.mass, moment_of_inertia(b), b.com)
        self.joints[j.name] = joint
        self._actuate(j.name, j.control)
        return node

    def _actuate(self, joint: str, control: Control | str) -> None:
        kind = (dart.dynamics.ActuatorType.VELOCITY if Control(control) == Control.VELOCITY
                else dart.dynamics.ActuatorType.FORCE)
        j = self.joints[joint]
        j.setActuatorType(kind)
        # the articulated inertia is cached: a kinematic (VELOCITY) joint makes its subtree
        # infinitely heavy, and switching it to FORCE otherwise leaves the subtree frozen
        j.getSkeleton().dirtyArticulatedInertia(j.getTreeIndex())

    def _build_sites(self, scene: Scene) -> None:
        """Site bodies per pair, side and kind of primitive (module docstring) and the filter
        that lets a site collide only with its partner's sites of a :data:`COLLIDING` kind."""
        self._site_of: dict[str, tuple[str, str]] = {}  # shape node name -> (pair, side)
        self._spheres: dict[str, dart.dynamics.SphereShape] = {}
        #: largest growth [m] of a sphere by :meth:`_keep_touching`
        self.inflation = 0.0
        self._floor = DEPTH_FLOOR_OF_SCALE * scene.length_scale
        self._site_shapes: dict[str, list[dart.dynamics.ShapeNode]] = {}
        sites: list[tuple[str, str, str, dart.dynamics.BodyNode]] = []
        for p in scene.pairs:
            self._site_shapes[p.name] = []
            for side, body, index in (("a", p.body_a, p.shape_a), ("b", p.body_b, p.shape_b)):
                parent = self.nodes[body]
                shape = scene.body(body).shapes[index]
                for kind, prims in primitives(shape, scene.length_scale).items():
                    joint, node = parent.getSkeleton().createWeldJointAndBodyNodePair(parent)
                    node.setName(f"{p.name}#{side}:{kind}")
                    self._mass(node, self._light, self._light)
                    for k, (shp, rot, centre) in enumerate(prims):
                        sn = node.createShapeNode(shp)
                        sn.setName(f"{p.name}#{side}:{kind}{k}")
                        sn.setRelativeTransform(_iso(rot, centre))
                        sn.createCollisionAspect()
                        sn.createDynamicsAspect().setFrictionCoeff(float(p.mu_static))
                        self._site_of[sn.getName()] = (p.name, side)
                        if isinstance(shp, dart.dynamics.SphereShape):
                            self._spheres[sn.getName()] = shp
                        self._site_shapes[p.name].append(sn)
                    sites.append((p.name, side, kind, node))
        # the solver's own filter (one assigned to the returned option would not be kept)
        self._filter = self.world.getConstraintSolver().getCollisionOption().collisionFilter
        for i, (pi, si, ki, ni) in enumerate(sites):
            for pj, sj, kj, nj in sites[i + 1:]:
                if pi != pj or si == sj or not ((ki, kj) in COLLIDING or (kj, ki) in COLLIDING):
                    self._filter.addBodyNodePairToBlackList(ni, nj)
        for skel in self._skeletons:  # a pair between two links of one chain
            skel.enableSelfCollisionCheck()
            skel.disableAdjacentBodyCheck()

    def step(self, dt: float) -> None:
        states = self.state()
        jointed = {j.body for j in self.scene.joints}
        for b in self.scene.bodies:
            if b.kind == BodyKind.DRIVEN and b.twist is not None and b.name not in jointed:
                self.nodes[b.name].getParentJoint().setCommands(
                    np.array([float(v) for v in b.twist(self.t, states)]))
        for j in self.scene.joints:
            self.joints[j.name].setCommand(0, float(j.command(self.t, states)))
        for ld in self.scene.loads:
            node, body = self.nodes[ld.body], self.scene.body(ld.body)
            node.addExtForce([float(ld.force[0]), float(ld.force[1]), 0.0],
                             [float(body.com[0]), float(body.com[1]), 0.0], False, True)
            node.addExtTorque([0.0, 0.0, float(ld.moment)], False)
        if self.world.getTimeStep() != dt:
            self.world.setTimeStep(dt)
        self.world.step()
        self._states = None
        self.t += dt
        self._readings = self._read_contacts()

    def state(self) -> dict[str, BodyState]:
        if self._states is not None:  # unchanged since the last step
            return self._states
        out = {}
        for b in self.scene.bodies:
            node = self.nodes[b.name]
            tf = node.getWorldTransform()
            p, rot = tf.translation(), tf.rotation()
            v, w = node.getLinearVelocity(), node.getAngularVelocity()
            out[b.name] = BodyState(
                pose=(float(p[0]), float(p[1]), float(np.arctan2(rot[1, 0], rot[0, 0]))),
                twist=(float(v[0]), float(v[1]), float(w[2])))
        self._states = out
        return out

    def _read_contacts(self) -> dict[str, ContactReading]:
        """One reading per pair (contacts found at the step's start poses, the step's forces);
        several contacts of a pair (a flat edge on a face) are summed: force = sum, normal = the
        deepest one's, point = normal-force-weighted mean, depth = the largest; slip from the
        bodies' twists after the step at that point."""
        parts: dict[str, list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]] = {}
        for c in self.world.getLastCollisionResult().getContacts():
            name1 = c.collisionObject1.getShapeFrame().getName()
            first = self._site_of.get(name1)
            if first is None:
                continue
            if c.penetrationDepth < self._floor and float(np.dot(c.force, c.normal)) > 0:
                self._keep_touching(name1, c.collisionObject2.getShapeFrame().getName(),
                                    float(c.penetrationDepth))
            # DART: the normal points into collision object 1, the force is the force on it
            sign = 1.0 if first[1] == "b" else -1.0
            n3, f3 = sign * np.asarray(c.normal), sign * np.asarray(c.force)
            n = n3[:2] / max(float(np.linalg.norm(n3[:2])), 1e-300)
            parts.setdefault(first[0], []).append(
                (float(c.penetrationDepth), np.asarray(c.point, dtype=float)[:2], n, f3[:2]))
        states = self.state() if parts else {}
        out: dict[str, ContactReading] = {}
        for p in self.scene.pairs:
            items = parts.get(p.name)
            if not items:
                continue
            depth, point, n, _ = max(items, key=lambda it: it[0])
            f = np.sum([it[3] for it in items], axis=0)
            w = np.array([max(float(it[3] @ n), 0.0) for it in items])
            if len(items) > 1 and w.sum() > 0:
                point = np.sum([wi * it[1] for wi, it in zip(w, items)], axis=0) / w.sum()
            t = np.array([-n[1], n[0]])
            vt = point_velocity(states[p.body_b], point) - point_velocity(states[p.body_a], point)
            out[p.name] = ContactReading(
                present=True, point=(float(point[0]), float(point[1])),
                normal=(float(n[0]), float(n[1])), normal_force=float(f @ n),
                tangent_force=float(f @ t), slip_velocity=float(vt @ t), depth=depth)
        return out

    def _keep_touching(self, name1: str, name2: str, depth: float) -> None:
        """Grow a loaded contact's sphere by ``floor - depth`` (:data:`DEPTH_FLOOR_OF_SCALE`;
        a separating contact carries no force and is left to open)."""
        sphere = self._spheres.get(name1) or self._spheres[name2]  # every contact has one
        sphere.setRadius(sphere.getRadius() + self._floor - depth)
        self.inflation += self._floor - depth

    def contacts(self) -> dict[str, ContactReading]:
        return {p.name: self._readings.get(p.name, ABSENT) for p in self.scene.pairs}

    def set_friction(self, pair: str, mu: float) -> None:
        if pair not in self._site_shapes:
            raise InputError(f"set_friction: expected a pair of the scene "
                             f"{sorted(self._site_shapes)}, got {pair!r}")
        for sn in self._site_shapes[pair]:
            sn.getDynamicsAspect().setFrictionCoeff(float(mu))

    @property
    def unconverged(self) -> int:
        """Contact solves that stopped at :data:`NSGS_MAX_SWEEPS` before
        :data:`NSGS_TOLERANCE` (two solves per step: velocities and split-impulse positions)."""
        stats = self._solver.getStats()
        return int(stats.numSolves - stats.numConverged)

    @property
    def solves(self) -> int:
        """Contact solves so far (two per step with contacts), of which :attr:`unconverged`
        stopped at the cap."""
        return int(self._solver.getStats().numSolves)

    def health(self) -> str | None:
        """A reason when a skeleton's coordinates or velocities are no longer finite. (Capped
        contact solves, :attr:`unconverged`, are no alarm: force-indeterminate supports and
        stacked blocks cap many solves and still agree; docs/engine-dart.md, "Limits".)"""
        for skel in self._skeletons:
            if not (np.all(np.isfinite(skel.getPositions()))
                    and np.all(np.isfinite(skel.getVelocities()))):
                return f"DART: non-finite state of {skel.getName()!r}"
        return None

    def set_control(self, joint: str, control: Control | str) -> None:
        """Switch revolute joint ``joint`` to ``control`` from the next step on (DART's
        ``VELOCITY`` or ``FORCE`` actuator); its ``command`` must then return that quantity."""
        j = switch_joint(self.scene, joint, control)
        if j is None:
            return
        self._actuate(j.name, control)
        self.scene = replace_joint(self.scene, j, control)
