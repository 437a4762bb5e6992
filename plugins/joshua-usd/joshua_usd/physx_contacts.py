"""MuJoCo's `cfrc_ext` from PhysX's contact report, for the NUMPY and the JAX PhysX environments alike.

MuJoCo's cfrc_ext of a body is its contact wrench in the world frame, [torque; force], the torque about the
centre of mass of the body's whole robot (`subtree_com` of its root). PhysX reports per link the net normal and
friction forces and each contact point's normal force, position and normal (ovphysx's raw contact data;
friction anchors come only with filtered bindings). So the force is the net normal plus friction force; the
torque sums each contact point's normal force about the centre, and applies the net friction force at the
link's normal-force-weighted contact centre: exact for one contact point (a foot), an approximation for a link
with several.

The contact points come in one array whose length varies with the contacts: a Warp kernel (on the CPU or the
GPU where PhysX's state lives) reduces them to fixed per-link sums about each clone's lane origin, and
`contact_wrench` (numpy or jax.numpy) turns those into cfrc_ext once the robot's centre of mass is known.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp

# per link: sum of (point - lane) x normal force (3), of normal forces (3), of |normal force| (point - lane) (3),
# and of |normal force| (1)
SUMS = 10


@wp.kernel
def _contact_sums(
    magnitude: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
    position: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
    normal: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
    layout: wp.array2d(dtype=wp.int32),  # type: ignore[valid-type]
    lanes: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
    sums: wp.array2d(dtype=wp.float32),  # type: ignore[valid-type]
) -> None:
    sensor = wp.tid()
    lane = wp.vec3(lanes[sensor, 0], lanes[sensor, 1], lanes[sensor, 2])
    moment = wp.vec3(0.0)
    force = wp.vec3(0.0)
    weighted = wp.vec3(0.0)
    weight = float(0.0)  # noqa: UP018 -- Warp mutates a loop variable only if declared by its type
    start = layout[sensor, 1]
    for k in range(layout[sensor, 0]):
        i = start + k
        if i < magnitude.shape[0]:  # a read that overflowed kept the first contacts
            m = magnitude[i, 0]
            point = wp.vec3(position[i, 0], position[i, 1], position[i, 2]) - lane
            f = m * wp.vec3(normal[i, 0], normal[i, 1], normal[i, 2])
            moment += wp.cross(point, f)
            force += f
            weighted += m * point
            weight += m
    for j in range(3):
        sums[sensor, j] = moment[j]
        sums[sensor, 3 + j] = force[j]
        sums[sensor, 6 + j] = weighted[j]
    sums[sensor, 9] = weight


class ContactReader:
    """Reads a PhysX scene's contact report into per-link arrays on `device` ("cpu" or "cuda:N"): the net normal
    and friction forces (2, links, 3) and the contact-point sums (links, SUMS). `scene` is a
    `joshua_usd.physx.PhysxScene` whose links report contacts; its contact binding grows when a step reports more
    contact points than it has room for (that read keeps the first ones)."""

    def __init__(self, scene: Any, device: str) -> None:
        self.scene = scene
        self.device = device
        links = len(scene.bodies)
        lanes = np.repeat(scene.offsets, links, axis=0).astype(np.float32)
        self._lanes: wp.array = wp.array(lanes, dtype=wp.float32, device=device)
        self._allocate()

    def _allocate(self) -> None:
        capacity, sensors, device = self.scene.contact_capacity, len(self.scene.sensors), self.device
        self._points = (
            wp.zeros((capacity, 1), dtype=wp.float32, device=device),  # normal force (N)
            wp.zeros((capacity, 3), dtype=wp.float32, device=device),  # world position
            wp.zeros((capacity, 3), dtype=wp.float32, device=device),  # unit normal, towards the link
            wp.zeros((capacity, 1), dtype=wp.float32, device=device),  # separation
            wp.zeros((sensors, 2), dtype=wp.int32, device=device),  # per link: count, start
            wp.zeros((capacity, 2), dtype=wp.int64, device=device),  # actor ids
        )

    def read(self, normal: Any, friction: Any, sums: Any) -> None:
        """Net normal and friction forces (links, 3) each, and the contact-point sums (links, SUMS), into the given
        arrays (numpy on the CPU, Warp arrays on `device`)."""
        contacts = self.scene.contacts
        contacts.read_net_normal_forces(normal)
        contacts.read_net_friction_forces(friction)
        required = contacts.read_raw_contact_data(*self._points)
        magnitude, position, unit_normal, _, layout, _ = self._points
        out = sums if isinstance(sums, wp.array) else wp.array(sums, dtype=wp.float32, device="cpu", copy=False)
        wp.launch(
            _contact_sums,
            dim=len(self.scene.sensors),
            inputs=[magnitude, position, unit_normal, layout, self._lanes],
            outputs=[out],
            device=self.device,
        )
        if required > magnitude.shape[0]:  # the next reads get room for every contact point
            self.scene.bind_contacts(2 * required)
            self._allocate()
