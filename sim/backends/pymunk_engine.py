"""pymunk (Chipmunk2D) backend of :class:`sim.scene.Backend`.

Settings (docs/simulation-measurements.md, "Engine facts"): gravity off (loads are explicit),
``collision_slop`` scaled to the scene (``1e-4 * length_scale``), many solver iterations, per-pair
friction set on the arbiter in a pre-solve callback (pymunk otherwise multiplies the two shapes'
friction values), one shape per contact site so one arbiter holds one contact; a round shape that
would sit exactly on the line of a polygon edge it is paired with is moved off it
(:mod:`sim.backends.pymunk_edges`: Chipmunk reports such a contact along the edge's normal at the
depth of the radius). Driven bodies are kinematic bodies; velocity joints: revolute = pivot +
SimpleMotor of unbounded force, prismatic = the body itself kinematic, moved along the axis at the
rate (held to a carriage by a pivot and a gear, a light link slowed the solver's sweeps on the
next joint until it came off: :mod:`sim.backends.pymunk_solver`); effort joints: pivot (or
groove + gear) with the effort applied as a body torque / force every step. Joints on a parent
body (chains, :meth:`PymunkBackend._add_child_joint`): the same constraints between the two
bodies, efforts applied equal and opposite. """


from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pymunk

from planner.errors import InputError
from sim.backends.pymunk_edges import edge_line_offsets
from sim.backends.pymunk_solver import slid_bodies
from sim.backends.switching import replace_joint, switch_joint
from sim.scene import (
    ABSENT,
    Body,
    BodyKind,
    BodyState,
    Capsule,
    Circle,
    ContactReading,
    Control,
    Joint,
    JointKind,
    Polygon,
    Scene,
)


def _moment(body: Body) -> float:
    if body.inertia is not None:
        return float(body.inertia)
    com = np.asarray(body.com, dtype=float)
    shape = body.shapes[0]
    if isinstance(shape, Polygon):
        verts = [tuple(v - com) for v in np.asarray(shape.vertices, dtype=float)]
        return float(pymunk.moment_for_poly(body.mass, verts))
    if isinstance(shape, Circle):
        off = tuple(np.asarray(shape.center) - com)
        return float(pymunk.moment_for_circle(body.mass, 0.0, shape.radius, off))
    a = tuple(np.asarray(shape.a) - com)
    b = tuple(np.asarray(shape.b) - com)
    return float(pymunk.moment_for_segment(body.mass, a, b, shape.radius))


def _xy(v: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """A 2-vector as the ``(x, y)`` tuple pymunk takes."""
    return (float(v[0]), float(v[1]))


class PymunkBackend:
    """Chipmunk2D via pymunk 7."""

    name = "pymunk"

    def __init__(self, iterations: int = 60) -> None:
        self.iterations = iterations
        self.t = 0.0

    # -- construction ------------------------------------------------------------------
    def build(self, scene: Scene) -> None:
        self.scene = scene
        space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.iterations = self.iterations
        space.collision_slop = 1e-4 * scene.length_scale
        self.space = space
        self.bodies: dict[str, pymunk.Body] = {}
        self.shapes: dict[str, list[pymunk.Shape]] = {}
        offsets = edge_line_offsets(scene)
        # a body slid by a velocity-controlled joint on the base has no free coordinate:
        # it is kinematic, moved at the joint's rate (not a light body held to a carriage,
        # whose joint rows slow the solver's sweeps; docs/simulation.md, "pymunk")
        slid = slid_bodies(scene)
        for b in scene.bodies:
            if b.kind == BodyKind.STATIC:
                body = pymunk.Body(body_type=pymunk.Body.STATIC)
            elif b.kind == BodyKind.DRIVEN or b.name in slid:
                body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            else:
                body = pymunk.Body(b.mass, _moment(b))
                body.center_of_gravity = _xy(b.com)
            # angle first: Chipmunk keeps the centre of gravity fixed when the angle is set
            body.angle = b.pose[2]
            body.position = (b.pose[0], b.pose[1])
            shapes: list[pymunk.Shape] = []
            for k, s in enumerate(b.shapes):
                off = np.asarray(offsets.get((b.name, k), (0.0, 0.0)))
                if isinstance(s, Polygon):
                    shp: pymunk.Shape = pymunk.Poly(body, [_xy(v) for v in s.vertices])
                elif isinstance(s, Circle):
                    shp = pymunk.Circle(body, s.radius, _xy(np.add(s.center, off)))
                elif isinstance(s, Capsule):
                    shp = pymunk.Segment(body, _xy(np.add(s.a, off)), _xy(np.add(s.b, off)),
                                         s.radius)
                else:  # pragma: no cover - guarded by the Shape union
                    raise TypeError(type(s))
                shp.friction = 0.0
                shapes.append(shp)
            space.add(body, *shapes)
            self.bodies[b.name] = body
            self.shapes[b.name] = shapes
        # joints
        self.carriages: dict[str, pymunk.Body] = {}
        self._slide_axes: dict[str, tuple[pymunk.Vec2d, pymunk.Vec2d]] = {}
        self._slides: dict[str, pymunk.SlideJoint] = {}
        self.motors: dict[str, pymunk.SimpleMotor] = {}
        static = space.static_body
        for j in scene.joints:
            body = self.bodies[j.body]
            if j.parent is not None:
                self._add_child_joint(j, j.parent)
            elif j.kind == JointKind.REVOLUTE:
                space.add(pymunk.PivotJoint(static, body, _xy(j.anchor)))
                if j.control == Control.VELOCITY:
                    motor = pymunk.SimpleMotor(static, body, 0.0)
                    motor.max_force = float("inf")
                    space.add(motor)
                    self.motors[j.name] = motor
            else:
                if j.control == Control.VELOCITY:
                    self.carriages[j.name] = body  # kinematic (``slid``), moved at the rate
                else:
                    axis = np.asarray(j.axis, dtype=float)
                    anchor = np.asarray(j.anchor, dtype=float)
                    a = _xy(anchor - 100.0 * scene.length_scale * axis)
                    bb = _xy(anchor + 100.0 * scene.length_scale * axis)
                    space.add(pymunk.GrooveJoint(static, body, a, bb,
                                                 body.world_to_local(_xy(anchor))),
                              pymunk.GearJoint(static, body, body.angle, 1.0))
        # contact pairs: one collision type per manipulator shape, one per workpiece shape
        self._readings: dict[str, ContactReading] = {}
        self._mu: dict[str, float] = {}
        self._by_shapes: dict[tuple[int, int], str] = {}
        next_type = 1
        types: dict[int, int] = {}
        for p in scene.pairs:
            sa = self.shapes[p.body_a][p.shape_a]
            sb = self.shapes[p.body_b][p.shape_b]
            for shp in (sa, sb):
                if id(shp) not in types:
                    types[id(shp)] = next_type
                    shp.collision_type = next_type
                    next_type += 1
            self._mu[p.name] = float(p.mu_static)
            self._by_shapes[(id(sa), id(sb))] = p.name
            space.on_collision(sa.collision_type, sb.collision_type,
                               pre_solve=self._pre_solve, post_solve=self._post_solve,
                               data=p.name)
        if scene.only_pairs:
            self._filter_to_pairs(scene)

    def _filter_to_pairs(self, scene: Scene) -> None:
        """Category bit per paired shape, mask = bits of its partners; unpaired shapes collide
        with nothing (Chipmunk collides a and b when a.categories & b.mask and vice versa)."""
        bit: dict[int, int] = {}
        for p in scene.pairs:
            for s in (self.shapes[p.body_a][p.shape_a], self.shapes[p.body_b][p.shape_b]):
                bit.setdefault(id(s), 1 << len(bit))
        if len(bit) > 32:
            raise InputError(f"only_pairs: expected at most 32 paired shapes, got {len(bit)}")
        mask = dict.fromkeys(bit, 0)
        for p in scene.pairs:
            a = id(self.shapes[p.body_a][p.shape_a])
            b = id(self.shapes[p.body_b][p.shape_b])
            mask[a] |= bit[b]
            mask[b] |= bit[a]
        for shapes in self.shapes.values():
            for s in shapes:
                s.filter = (pymunk.ShapeFilter(categories=bit[id(s)], mask=mask[id(s)])
                            if id(s) in bit else pymunk.ShapeFilter(categories=0, mask=0))

    def _pre_solve(self, arbiter: pymunk.Arbiter, space: pymunk.Space, name: str) -> None:
        arbiter.friction = self._mu[name]

    def _post_solve(self, arbiter: pymunk.Arbiter, space: pymunk.Space, name: str) -> None:
        sa, sb = arbiter.shapes
        if (id(sa), id(sb)) != next(k for k, v in self._by_shapes.items() if v == name):
            return  # pragma: no cover - pymunk orders the shapes as registered
        pts = arbiter.contact_point_set
        if not pts.points:
            return
        cp = pts.points[0]
        point = 0.5 * (np.asarray(cp.point_a) + np.asarray(cp.point_b))
        n = np.asarray(arbiter.normal, dtype=float)  # from shape a into shape b
        t = np.array([-n[1], n[0]])
        imp = np.asarray(arbiter.total_impulse, dtype=float) / self._dt
        sign = 1.0 if float(imp @ n) >= 0 else -1.0  # total_impulse is the impulse on a or b
        f = sign * imp
        body_a, body_b = sa.body, sb.body
        if body_a is None or body_b is None:  # pragma: no cover - every shape has a body
            return
        va = np.asarray(body_a.velocity_at_world_point(_xy(point)))
        vb = np.asarray(body_b.velocity_at_world_point(_xy(point)))
        self._readings[name] = ContactReading(
            present=True,
            point=(float(point[0]), float(point[1])),
            normal=(float(n[0]), float(n[1])),
            normal_force=float(f @ n),
            tangent_force=float(f @ t),
            slip_velocity=float((vb - va) @ t),
            depth=float(-cp.distance),
        )

    # -- chains: joints between two bodies ---------------------------------------------
    def _add_child_joint(self, j: Joint, parent_name: str) -> None:
        """A joint of ``j.body`` on its parent body (a chain link on the previous link).

        Revolute: pivot at the anchor; velocity control by a ``SimpleMotor`` of unbounded
        force on the relative rate, effort control by equal and opposite body torques.
        Prismatic: a groove along the axis on the parent (fixed in the parent's frame) and a
        gear joint holding the relative angle; effort control by equal and opposite forces at
        the anchor; velocity control (Chipmunk has no linear motor) by a slide joint of equal
        min and max distance from a point on the axis, moved by ``u dt`` every step with
        ``error_bias = 0`` (the solver closes the whole distance error in the step)."""
        parent, body = self.bodies[parent_name], self.bodies[j.body]
        space = self.space
        if j.kind == JointKind.REVOLUTE:
            space.add(pymunk.PivotJoint(parent, body, _xy(j.anchor)))
            if j.control == Control.VELOCITY:
                motor = pymunk.SimpleMotor(parent, body, 0.0)
                motor.max_force = float("inf")
                space.add(motor)
                self.motors[j.name] = motor
            return
        axis = np.asarray(j.axis, dtype=float)
        anchor = np.asarray(j.anchor, dtype=float)
        reach = 100.0 * self.scene.length_scale
        ga = parent.world_to_local(_xy(anchor - reach * axis))
        gb = parent.world_to_local(_xy(anchor + reach * axis))
        space.add(pymunk.GrooveJoint(parent, body, ga, gb, body.world_to_local(_xy(anchor))),
                  pymunk.GearJoint(parent, body, body.angle - parent.angle, 1.0))
        if j.control == Control.VELOCITY:
            # the slide as a distance from a point one length scale back on the axis, its
            # target moved by u dt each step; error_bias 0 corrects the whole error in one step,
            # so the relative slide velocity is the command
            back = self.scene.length_scale
            slide = pymunk.SlideJoint(parent, body,
                                      parent.world_to_local(_xy(anchor - back * axis)),
                                      body.world_to_local(_xy(anchor)), back, back)
            slide.error_bias = 0.0
            space.add(slide)
            self._slides[j.name] = slide
            return
        self._slide_axes[j.name] = (parent.world_to_local(_xy(anchor + axis))
                                    - parent.world_to_local(_xy(anchor)),
                                    body.world_to_local(_xy(anchor)))

    def _command_child_joint(self, j: Joint, parent_name: str, u: float) -> None:
        """Apply one step's command of a joint on a parent body (see :meth:`_add_child_joint`)."""
        parent, body = self.bodies[parent_name], self.bodies[j.body]
        if j.kind == JointKind.REVOLUTE:
            if j.control == Control.VELOCITY:
                self.motors[j.name].rate = -u  # Chipmunk drives w_a - w_b = rate
            else:
                body.torque = body.torque + u
                parent.torque = parent.torque - u
            return
        if j.control == Control.VELOCITY:
            slide = self._slides[j.name]
            slide.min = slide.max = slide.max + u * self._dt
            return
        axis_local, anchor_local = self._slide_axes[j.name]
        axis = np.asarray(axis_local.rotated(parent.angle), dtype=float)
        at = body.local_to_world(anchor_local)
        body.apply_force_at_world_point(_xy(u * axis), at)
        parent.apply_force_at_world_point(_xy(-u * axis), at)

    # -- stepping ----------------------------------------------------------------------
    def _states_now(self) -> Mapping[str, BodyState]:
        return self.state()

    def step(self, dt: float) -> None:
        self._dt = dt
        states = self.state()
        for b in self.scene.bodies:
            if b.kind == BodyKind.DRIVEN and b.twist is not None:
                vx, vy, w = (float(v) for v in b.twist(self.t, states))
                body = self.bodies[b.name]
                body.velocity = (vx, vy)
                body.angular_velocity = w
        for j in self.scene.joints:
            u = float(j.command(self.t, states))
            body = self.bodies[j.body]
            if j.parent is not None:
                self._command_child_joint(j, j.parent, u)
            elif j.kind == JointKind.REVOLUTE:
                if j.control == Control.VELOCITY:
                    self.motors[j.name].rate = -u  # Chipmunk drives w_a - w_b = rate
                else:
                    body.torque = body.torque + u
            else:
                axis = np.asarray(j.axis, dtype=float)
                if j.control == Control.VELOCITY:
                    self.carriages[j.name].velocity = _xy(u * axis)
                else:
                    body.apply_force_at_world_point(_xy(u * axis),
                                                    body.local_to_world(body.center_of_gravity))
        for ld in self.scene.loads:
            body = self.bodies[ld.body]
            body.apply_force_at_world_point(_xy(ld.force),
                                            body.local_to_world(body.center_of_gravity))
            body.torque = body.torque + ld.moment
        self._readings = {}
        self.space.step(dt)
        self.t += dt

    # -- readout -----------------------------------------------------------------------
    def state(self) -> dict[str, BodyState]:
        out = {}
        for name, body in self.bodies.items():
            pos = body.position
            v = body.velocity_at_world_point(pos)
            out[name] = BodyState(
                pose=(float(pos.x), float(pos.y), float(body.angle)),
                twist=(float(v.x), float(v.y), float(body.angular_velocity)),
            )
        return out

    def contacts(self) -> dict[str, ContactReading]:
        return {p.name: self._readings.get(p.name, ABSENT) for p in self.scene.pairs}

    def set_friction(self, pair: str, mu: float) -> None:
        self._mu[pair] = float(mu)

    def health(self) -> str | None:
        """pymunk raises no numerical alarm of its own (non-finite states and exceptions its
        callbacks swallow are caught by the run loop, :class:`sim.run.EngineWatch`)."""
        return None

    # -- control switching (a whole task: segments with other control partitions) ----------
    def set_control(self, joint: str, control: Control | str) -> None:
        """Switch revolute joint ``joint`` to ``control`` from the next step on: velocity
        control adds a ``SimpleMotor`` of unbounded force (to the base or the parent link),
        effort control removes it (the joint's command is then a torque). The joint's
        ``command`` callback stays; it must return the quantity of the new control."""
        j = switch_joint(self.scene, joint, control)
        if j is None:
            return
        if control == Control.VELOCITY:
            parent = self.space.static_body if j.parent is None else self.bodies[j.parent]
            motor = pymunk.SimpleMotor(parent, self.bodies[j.body], 0.0)
            motor.max_force = float("inf")
            self.space.add(motor)
            self.motors[j.name] = motor
        else:
            self.space.remove(self.motors.pop(j.name))
        self.scene = replace_joint(self.scene, j, control)

