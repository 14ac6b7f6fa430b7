// @ts-check
/**
 * The desktop's keyboard (and gamepad): Space and Esc are E-STOP from anywhere on the page; H/Home, T and F choose a
 * view (view/desktop_views.js); with Teleop on, WASD/arrows and a gamepad's left stick drive the selected robot
 * through the teleop loop; otherwise WASD/QE and the arrows fly the camera along the ground. I/K, J/L and U/O move
 * the selected robot's arm, [ and ] open and close its gripper (arm_jog.js). Listeners are added in the constructor
 * and removed in dispose().
 */
import * as THREE from 'three';
import { keysToStick } from '../teleop.js';
import { ARM_KEYS, GRIPPER_KEYS, keysToArmTwist } from '../arm_jog.js';
import { typingIn } from './typing.js';

const FLY_SPEED = 4; // m/s
const MOVE_KEYS = ['KeyW', 'KeyA', 'KeyS', 'KeyD', 'KeyQ', 'KeyE', 'ArrowUp', 'ArrowDown', 'ArrowLeft', 'ArrowRight'];

export class DesktopKeys {
  /**
   * @param {{camera: THREE.PerspectiveCamera, menu: import('../menu_state.js').MenuState,
   *   actions: import('../app.js').OperatorActions, presenting: () => boolean}} host what the keys read and drive
   * @param {import('three/addons/controls/OrbitControls.js').OrbitControls} orbit flown with the camera
   * @param {import('./desktop_views.js').DesktopViews} views chosen by key; flying ends their automatic framing
   */
  constructor(host, orbit, views) {
    this.host = host;
    this.orbit = orbit;
    this.views = views;
    /** @type {Set<string>} */
    this.keys = new Set();
    /**
     * Keys pressed while Teleop was on: they drove the robot, and never fly the camera (an E-STOP that turns Teleop
     * off under a held W must not send the view away). Released, they are forgotten. @type {Set<string>}
     */
    this.driving = new Set();
    /** Held keys that move the selected robot's arm. @type {Set<string>} */
    this.arm = new Set();
    /** @type {(() => void)[]} */
    this.unlisten = [];
    const on = (/** @type {string} */ type, /** @type {(e: any) => void} */ fn) => {
      window.addEventListener(type, fn);
      this.unlisten.push(() => window.removeEventListener(type, fn));
    };
    on('keydown', (e) => this.#key(e, true));
    on('keyup', (e) => this.#key(e, false));
    on('blur', () => (this.keys.clear(), this.driving.clear(), this.arm.clear()));
  }

  /** @param {KeyboardEvent} e @param {boolean} down */
  #key(e, down) {
    const target = /** @type {HTMLElement} */ (e.target);
    const typing = typingIn(target);
    const code = e.code;
    // Space and Esc are E-STOP from anywhere on the page, a dialog open or not (a dialog that kept them would hold
    // the stop back while it waits for an answer). Space types a space only in a field whose text may have one (the
    // operator's name: data-space="text"); elsewhere it never reaches a focused button as a click. Esc keeps its
    // default too: it also cancels the dialog it was pressed in.
    if (code === 'Escape' || (code === 'Space' && !(typing && target.dataset.space === 'text'))) {
      if (code === 'Space') e.preventDefault();
      if (down && !e.repeat && !this.host.presenting()) this.host.actions.pressMenu('estop');
      return;
    }
    if (typing) return;
    const view = { KeyH: 'frame', Home: 'frame', KeyT: 'top', KeyF: 'follow' }[code];
    if (view && !e.ctrlKey && !e.metaKey && !e.altKey) {
      if (down && !e.repeat && !this.host.presenting()) this.views.choose(view);
      return;
    }
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    if (code in ARM_KEYS) {
      if (down) this.arm.add(code);
      else this.arm.delete(code);
      this.pollTeleop();
      return;
    }
    if (code in GRIPPER_KEYS) {
      if (down && !e.repeat && !this.host.presenting()) this.host.actions.grip(GRIPPER_KEYS[code]);
      return;
    }
    if (!MOVE_KEYS.includes(code)) return;
    e.preventDefault();
    if (down) this.keys.add(code);
    else this.keys.delete(code);
    if (down && this.host.menu.tool === 'teleop') this.driving.add(code);
    if (!down) this.driving.delete(code);
    if (this.host.menu.tool === 'teleop') this.pollTeleop();
  }

  /** Keyboard and gamepad into the teleop loop: called on key changes and by the station's 100 Hz timer. */
  pollTeleop() {
    if (this.host.presenting()) return;
    this.host.actions.jogArm(keysToArmTwist(this.arm));
    if (this.host.menu.tool !== 'teleop') return;
    const [kx, ky] = keysToStick(this.keys);
    this.host.actions.driveStick('keyboard', kx, ky);
    const pad = [...(navigator.getGamepads?.() ?? [])].find((g) => g && g.mapping === 'standard' && g.connected);
    if (pad) this.host.actions.driveStick('gamepad', pad.axes[0] ?? 0, pad.axes[1] ?? 0);
  }

  /**
   * Fly with the keys that do not drive: the camera and its orbit target move together, along the ground.
   * @param {number} dt s
   */
  fly(dt) {
    const flying = new Set([...this.keys].filter((k) => !this.driving.has(k)));
    if (this.host.menu.tool === 'teleop' || flying.size === 0) return;
    const [x, y] = keysToStick(flying);
    const up = (flying.has('KeyE') ? 1 : 0) - (flying.has('KeyQ') ? 1 : 0);
    const forward = new THREE.Vector3();
    this.host.camera.getWorldDirection(forward);
    forward.y = 0;
    forward.normalize();
    const right = new THREE.Vector3(-forward.z, 0, forward.x);
    const step = new THREE.Vector3()
      .addScaledVector(forward, -y)
      .addScaledVector(right, x)
      .addScaledVector(new THREE.Vector3(0, 1, 0), up)
      .multiplyScalar(FLY_SPEED * dt);
    this.host.camera.position.add(step);
    this.orbit.target.add(step);
    this.views.auto = null;
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
  }
}
