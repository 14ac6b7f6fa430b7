"""Driving IWER's emulated Quest 3 from a test: aim a controller at a world point, pull its trigger, press
its buttons, push its stick. Controller poses are in the XR reference space (local-floor), which the client's
rig carries through the scene; the rig's pose comes from the client's state."""

from __future__ import annotations

import math
from typing import Any

from playwright.async_api import Page
from playwright.async_api import TimeoutError as PlaywrightTimeout

from tests.helpers.browser import HEADSET, SOFTWARE_GL, VR_VIEW, Client, OpenClient

# In the corridor, in sight of where VR starts (the relay's vantage: the corridor's west end, facing the fleet).
GOAL = (7.0, 2.0)

#: Where the emulated hands are held, in the reference space (metres): in front of the chest.
HAND_ORIGIN = {"left": [-0.2, 1.35, -0.25], "right": [0.2, 1.35, -0.25]}

_AIM = """
async ([hand, origin, target, kind]) => {
  const THREE = await import('three');
  const s = window.__xrRelay.state;
  const rigPosition = new THREE.Vector3(...s.rig.position);
  const rigRotation = new THREE.Quaternion(...s.rig.quaternion);
  const from = new THREE.Vector3(...origin).applyQuaternion(rigRotation).add(rigPosition);
  const direction = new THREE.Vector3(...target).sub(from).normalize().applyQuaternion(rigRotation.clone().invert());
  const q = new THREE.Quaternion().setFromUnitVectors(new THREE.Vector3(0, 0, -1), direction);
  const c = kind === 'hand' ? window.__iwer.hands[hand] : window.__iwer.controllers[hand];
  c.position.set(...origin);
  c.quaternion.set(q.x, q.y, q.z, q.w);
}
"""

# Aim so that the client's pointer arc (src/arc.js, the same function the client uses) lands on a point of
# the floor: bisect the pitch, the yaw pointing at the target.
_AIM_ARC = """
async ([hand, origin, target, kind]) => {
  const THREE = await import('three');
  const { arcPoints } = await import('/src/arc.js');
  const s = window.__xrRelay.state;
  const rigPosition = new THREE.Vector3(...s.rig.position);
  const rigRotation = new THREE.Quaternion(...s.rig.quaternion);
  const from = new THREE.Vector3(...origin).applyQuaternion(rigRotation).add(rigPosition);
  const flat = new THREE.Vector3(target[0] - from.x, 0, target[2] - from.z);
  const want = flat.length();
  flat.normalize();
  const dir = (pitch) => new THREE.Vector3(flat.x * Math.cos(pitch), Math.sin(pitch), flat.z * Math.cos(pitch));
  const reach = (pitch) => {
    const d = dir(pitch);
    const { hit } = arcPoints([from.x, from.y, from.z], [d.x, d.y, d.z], { floorY: target[1], maxPoints: 400 });
    return hit ? Math.hypot(hit[0] - from.x, hit[2] - from.z) : Infinity;
  };
  let lo = -1.2, hi = 0.7;
  for (let i = 0; i < 50; i++) {
    const mid = (lo + hi) / 2;
    if (reach(mid) < want) lo = mid; else hi = mid;
  }
  const world = dir((lo + hi) / 2);
  const local = world.applyQuaternion(rigRotation.clone().invert());
  const q = new THREE.Quaternion().setFromUnitVectors(new THREE.Vector3(0, 0, -1), local);
  const c = kind === 'hand' ? window.__iwer.hands[hand] : window.__iwer.controllers[hand];
  c.position.set(...origin);
  c.quaternion.set(q.x, q.y, q.z, q.w);
}
"""


#: Turn the right controller by an angle about a world axis (the reference space is the rig's: the axis is turned
#: into it), on the next XR frame.
_TURN = """
async ([axis, angle]) => {
  const THREE = await import('three');
  const rig = new THREE.Quaternion(...window.__xrRelay.state.rig.quaternion);
  const local = new THREE.Vector3(...axis).applyQuaternion(rig.invert()).normalize();
  const c = window.__iwer.controllers.right;
  const turned = new THREE.Quaternion().setFromAxisAngle(local, angle)
    .multiply(new THREE.Quaternion(c.quaternion.x, c.quaternion.y, c.quaternion.z, c.quaternion.w));
  c.quaternion.set(turned.x, turned.y, turned.z, turned.w);
}
"""


#: The right controller (``device`` 'controller') or the headset ('head') at a world point: the reference space is the
#: rig's (position, turn), as ``aim`` aims.
_PUT_AT = """
async ([world, device]) => {
  const THREE = await import('three');
  const s = window.__xrRelay.state;
  const rigRotation = new THREE.Quaternion(...s.rig.quaternion);
  const local = new THREE.Vector3(...world).sub(new THREE.Vector3(...s.rig.position))
    .applyQuaternion(rigRotation.invert());
  const moved = device === 'head' ? window.__iwer : window.__iwer.controllers.right;
  moved.position.set(local.x, local.y, local.z);
  return local.toArray();
}
"""


async def hand(page: Page, side: str, position: list[float], pinch: float | None = None) -> None:
    """Move one emulated hand (IWER's device space) and, with ``pinch``, close (1) or open (0) it."""
    await page.evaluate(
        "([side, p, pinch]) => { const h = window.__iwer.hands[side]; h.position.set(...p);"
        " if (pinch !== null) h.updatePinchValue(pinch); }",
        [side, position, pinch],
    )


async def turn(client: Client, axis: list[float], angle: float) -> None:
    """Turn the right controller by ``angle`` (rad) about a world axis, on the next XR frame."""
    await client.page.evaluate(_TURN, [axis, angle])


async def hold_at(client: Client, world: list[float], device: str = "controller") -> list[float]:
    """Put the right controller (or, ``device`` 'head', the headset) at a world point (it applies on the next XR
    frame); where it is in the reference space."""
    local: list[float] = await client.page.evaluate(_PUT_AT, [world, device])
    return local


async def aim(client: Client, hand: str, target: list[float], kind: str = "controller") -> None:
    """Point a controller's ray (``kind`` 'hand': IWER's emulated hand's) from where it is held at a world point."""
    await client.page.evaluate(_AIM, [hand, HAND_ORIGIN[hand], target, kind])
    await client.frames(2)


async def aim_arc(client: Client, hand: str, target: list[float], kind: str = "controller") -> None:
    """Aim so that the pointer arc lands on a floor point; ``kind`` 'hand' turns IWER's emulated hand instead."""
    await client.page.evaluate(_AIM_ARC, [hand, HAND_ORIGIN[hand], target, kind])
    await client.frames(2)


async def button(client: Client, hand: str, name: str, value: float) -> None:
    await client.page.evaluate(
        "([hand, name, value]) => window.__iwer.controllers[hand].updateButtonValue(name, value)", [hand, name, value]
    )


async def click(client: Client, hand: str, name: str = "trigger") -> None:
    """Press and release, a few frames apart so that the client sees both edges."""
    await button(client, hand, name, 1)
    await client.frames(2)
    await button(client, hand, name, 0)
    await client.frames(2)


async def stick(client: Client, hand: str, x: float, y: float) -> None:
    await client.page.evaluate(
        "([hand, x, y]) => window.__iwer.controllers[hand].updateAxes('thumbstick', x, y)", [hand, x, y]
    )


async def press_menu_button(client: Client, button_id: str, hand: str = "right") -> dict[str, Any]:
    """Point at a button of the open VR menu and pull the trigger."""
    s = await client.state()
    assert s["menu"]["open"], "the menu is closed"
    centre = s["menu"]["centres"][button_id]
    await aim(client, hand, centre)
    # The ray must be on the button (hover highlight) before the trigger is pulled.
    await client.wait("s.xr.hover[arg[0]] === arg[1]", 20, [hand, button_id])
    await click(client, hand)
    return await client.state()


async def reset_in_vr(client: Client, armed: bool = False) -> str:
    """Reset E-STOP from the open VR menu: the first press says whose E-STOP it lifts (the notice, in the view's
    toast), the second within the confirmation time resets. ``armed``: the first press was made already. Returns the
    notice. On SwiftShader's few frames a second (two pages beside each other on two cores) a press takes seconds: one
    that came after the confirmation time armed the question again, and the next press resets (three at most)."""
    if not armed:
        await press_menu_button(client, "estop:reset")
    notice: str = await client.wait("s.notice.startsWith('Reset the E-STOP') && s.notice", 10)
    for _ in range(3):
        await press_menu_button(client, "estop:reset")
        try:
            await client.wait("s.estop.latched.length === 0", 10)
            return notice
        except PlaywrightTimeout:
            continue
    raise AssertionError(f"three presses of Reset E-STOP after {notice!r} did not reset it")


async def set_menu(client: Client, open_: bool) -> None:
    """Open or close the menu with the left controller's Y button (one press, one toggle)."""
    s = await client.state()
    if s["menu"]["open"] == open_:
        return
    await button(client, "left", "y-button", 1)
    await client.wait(f"s.menu.open === {'true' if open_ else 'false'}")
    await client.frames(2)  # held: must not toggle again
    assert (await client.state())["menu"]["open"] == open_
    await button(client, "left", "y-button", 0)
    await client.frames(2)


async def teleop_on(client: Client, robot: str) -> None:
    """In VR, from the menu: select ``robot`` and turn Teleop on, then close the menu."""
    await set_menu(client, True)
    await press_menu_button(client, f"robot:{robot}")
    await press_menu_button(client, "tool:teleop")
    await client.wait("s.menu.selected === arg && s.menu.tool === 'teleop'", 20, robot)
    await set_menu(client, False)


#: Vision Pro's gaze-and-pinch, which IWER does not emulate: a `transient-pointer` XRInputSource made of IWER's own
#: classes (iwer exports XRInputSource, XRSpace, XRInputSourceEvent and its private symbols). IWER's session diffs
#: `device.inputSources` every frame (XRSession.updateActiveInputSources, which fires `inputsourceschange`), so the
#: source is added to that list; its target ray is an XRSpace under IWER's global space, aimed from the headset. The
#: events are fired from inside IWER's frame start, before the page's frame callback, in the order a real device
#: gives them: added, selectstart; while held, the ray follows `move`; select, selectend, removed.
_TRANSIENT_INSTALL = """
async () => {
  if (window.__transient) return;
  const iwer = await import('iwer');
  const { P_DEVICE, P_SESSION, P_SPACE, XRInputSource, XRSpace, XRInputSourceEvent } = iwer;
  const { XRRigidTransform, lookRotation } = iwer;
  const device = window.__iwer;
  const D = device[P_DEVICE];
  const extra = [];
  const base = Object.getOwnPropertyDescriptor(iwer.XRDevice.prototype, 'inputSources').get;
  Object.defineProperty(device, 'inputSources', {
    configurable: true,
    get() { return [...base.call(this), ...extra]; },
  });
  const state = { source: null, space: null, dir: null, pending: [], frames: 0 };
  const aim = () => {
    const pose = new XRRigidTransform(device.position, lookRotation(state.dir));
    state.space[P_SPACE].offsetMatrix.set(pose.matrix);
  };
  const orig = D.onFrameStart;
  D.onFrameStart = (frame) => {
    orig(frame);
    if (state.source) { aim(); state.frames++; }
    const S = device.activeSession?.[P_SESSION];
    const fire = (type) => device.activeSession.dispatchEvent(
      new XRInputSourceEvent(type, { frame, inputSource: state.source }),
    );
    for (const act of state.pending.splice(0)) {
      if (act.kind === 'begin') {
        state.space = new XRSpace(D.globalSpace);
        state.source = new XRInputSource(
          'none', 'transient-pointer', ['generic-button'], state.space, null, null, null,
        );
        state.dir = act.dir;
        state.frames = 0;
        aim();
        extra.push(state.source);
        S.updateActiveInputSources();
        fire('selectstart');
      } else if (state.source) {
        fire('select');
        fire('selectend');
        extra.splice(extra.indexOf(state.source), 1);
        S.updateActiveInputSources();
        state.source = null;
      }
      act.done();
    }
  };
  /** A world (scene) point to a direction in IWER's global space: from the eyes, the rig's turn undone. */
  const toward = async (target) => {
    const THREE = await import('three');
    const s = window.__xrRelay.state;
    const rig = new THREE.Quaternion(...s.rig.quaternion);
    const d = new THREE.Vector3(...target).sub(new THREE.Vector3(...s.eye));
    d.normalize().applyQuaternion(rig.invert());
    return { x: d.x, y: d.y, z: d.z };
  };
  window.__transient = {
    state,
    begin: async (target) => {
      const dir = await toward(target);
      await new Promise((done) => state.pending.push({ kind: 'begin', dir, done }));
    },
    move: async (target) => { state.dir = await toward(target); },
    end: () => new Promise((done) => state.pending.push({ kind: 'end', done })),
  };
}
"""


async def settled_point(client: Client, expression: str, frames: int = 2, tolerance: float = 0.01) -> list[float]:
    """A world point of the page's state (``expression`` over ``s``) once it stands still: the same within
    ``tolerance`` metres ``frames`` frames apart (what follows the head or a hand is where the last drawn frame put it,
    and it is still moving for a few frames after the head or the hand did)."""
    point: list[float] = await client.wait(expression, 10)
    for _ in range(10):
        await client.frames(frames)
        now: list[float] = await client.wait(expression, 10)
        if math.dist(now, point) < tolerance:
            return now
        point = now
    raise AssertionError(f"{expression} never stood still: {point}")


async def gaze_pinch(client: Client, target: list[float], drag_to: list[float] | None = None, hold: int = 3) -> None:
    """Look at a scene point and pinch (a transient pointer): held ``hold`` frames, dragged to ``drag_to`` if given."""
    await client.page.evaluate(_TRANSIENT_INSTALL)
    await client.page.evaluate("(t) => window.__transient.begin(t)", target)
    await client.frames(hold)
    if drag_to is not None:
        await client.page.evaluate("(t) => window.__transient.move(t)", drag_to)
        await client.frames(hold)
    await client.page.evaluate("() => window.__transient.end()")
    await client.frames(2)


async def enter_vr(open_client: OpenClient, url: str) -> Client:
    return await present(await open_client(f"{url}/?{HEADSET}&{SOFTWARE_GL}", "vr", *VR_VIEW))


async def present(client: Client) -> Client:
    """Enter VR on a page opened with the emulated headset."""
    await client.wait("s.vr.available", 10)
    await client.page.click("#enter-vr")
    await client.wait("s.presenting && s.rig.position[2] !== 0")
    await client.frames(5)
    return client


async def point_and_select(client: Client, point: list[float], hover: str) -> None:
    """Aim the right controller at a world point until its ray names ``hover``, and pull the trigger."""
    await aim(client, "right", point)
    await client.wait("s.xr.hover.right === arg", 20, hover)
    await click(client, "right")


async def open_finding_card(client: Client, finding: str, x: float, y: float) -> dict[str, Any]:
    """With robot1's Inspect tool, point at the pin of ``finding`` (at map x, y) and select it: its card, loaded."""
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot1")
    await press_menu_button(client, "tool:inspect")
    await client.wait("s.menu.tool === 'inspect'")
    await set_menu(client, False)
    await client.wait("arg in s.inspection.pinLooks", 30, finding)
    pin = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToScene(x, y, 1.25)", [x, y])
    await point_and_select(client, pin, f"insp:finding:{finding}")
    card: dict[str, Any] = await client.wait("(c => c.visible && c.image && c)(s.inspection.card)", 30)
    return card


async def press_card_button(client: Client, button: str) -> None:
    """Point at a button of the open finding card and select it."""
    points = await client.page.evaluate("() => window.__xrRelay.cardPoints(null)")
    await point_and_select(client, points[button], f"insp:card:{button}")
