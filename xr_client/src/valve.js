// @ts-check
/**
 * The simulated facility's valve wheel (`valve`, docs/protocol.md): where the twin draws it and how far it is turned.
 * The relay reports the wheel when it changes (sim backend, robots.yaml `sim.valve`); view/valve_view.js draws it.
 * No DOM, no WebGL: test/valve.test.js drives it.
 *
 * The wheel's axis is horizontal, along its `yaw` (the way its face looks); `angle` turns it right-handed about that
 * axis. Drawn in a frame whose +x is the axis and +y is up (glTF Y-up), a turn about the axis is a turn about +x.
 */
import { mapToScene, mapYawToScene } from './frames.js';

/**
 * Where the wheel sits in the scene: its centre (glTF), the turn about +y that points its local +x along its axis,
 * and its turn about that axis.
 * @param {import('./frames.js').MapToScene} t @param {import('./protocol.js').ValveMessage} valve
 * @returns {{position: [number, number, number], heading: number, angle: number}}
 */
export function valvePlacement(t, valve) {
  return {
    position: mapToScene(t, valve.x, valve.y, valve.z),
    heading: mapYawToScene(t, valve.yaw),
    angle: valve.angle,
  };
}
