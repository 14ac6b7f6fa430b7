// @ts-check
/**
 * What the operator wears in VR: the toast under the view, the sensor panel on the left wrist with the E-STOP
 * button under it, and the latched-estop banner at the top of the view. It follows the session (shown when it
 * starts, taken off when it ends) and is released by dispose().
 */
import { Toast } from './label_sprite.js';
import { WristPanel } from './panels.js';
import { EstopView } from './estop_view.js';

export class VRHud {
  /** @param {import('three').Camera} camera what the toast and the banner hang from */
  constructor(camera) {
    this.toast = new Toast(camera);
    this.wrist = new WristPanel();
    this.estop = new EstopView(camera);
  }

  /**
   * One VR frame: the wrist panel rides on the left grip (when that hand is tracked), and redraws when due.
   * @param {number} now ms @param {import('three').Object3D | null} leftGrip
   * @param {import('./sensor_drawing.js').SensorPanelData} data
   */
  update(now, leftGrip, data) {
    if (leftGrip && this.wrist.mesh.parent !== leftGrip) leftGrip.add(this.wrist.mesh);
    this.estop.attach(this.wrist.mesh);
    this.wrist.update(data);
    this.toast.update(now, true);
  }

  /** The session started: the banner shows if a stop is latched. @param {import('../estop_banner.js').EstopBanner | null} banner */
  started(banner) {
    this.estop.show(banner, true);
  }

  /** The session ended: nothing of it stays in the desktop's view. */
  ended() {
    this.wrist.mesh.removeFromParent();
    this.toast.update(0, false);
    this.estop.show(this.estop.shown, false);
  }

  dispose() {
    this.toast.dispose();
    this.wrist.dispose();
    this.estop.dispose();
  }
}
