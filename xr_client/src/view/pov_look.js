// @ts-check
/**
 * The desktop's Robot POV panel under the mouse: a drag looks around the hemisphere, the wheel zooms (the field of
 * view), and a click that did not drag marks where that point of the image looks (the Inspect tool). `look` is what
 * HemisphereScreen.renderInto draws the panel with. Listeners are added in the constructor and removed in dispose().
 */

export class PovLook {
  /**
   * @param {HTMLElement} panel the POV panel
   * @param {(x: number, y: number) => boolean} markPov a click on the image, in -1..1 across the panel (y up)
   */
  constructor(panel, markPov) {
    this.look = { yaw: 0, pitch: 0, fov: 100 };
    /** @type {{x: number, y: number, yaw: number, pitch: number} | null} */
    this.drag = null;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    const on = (
      /** @type {string} */ type,
      /** @type {(e: any) => void} */ fn,
      /** @type {AddEventListenerOptions} */ options = {},
    ) => {
      panel.addEventListener(type, fn, options);
      this.unlisten.push(() => panel.removeEventListener(type, fn, options));
    };
    on('pointerdown', (e) => {
      this.drag = { x: e.clientX, y: e.clientY, yaw: this.look.yaw, pitch: this.look.pitch };
      panel.setPointerCapture(e.pointerId);
    });
    on('pointermove', (e) => {
      if (!this.drag) return;
      const k = (this.look.fov / panel.clientHeight) * (Math.PI / 180);
      this.look.yaw = this.drag.yaw + (e.clientX - this.drag.x) * k;
      this.look.pitch = Math.max(-1.4, Math.min(1.4, this.drag.pitch + (e.clientY - this.drag.y) * k));
    });
    on('pointerup', (e) => {
      // A click that did not drag the view: with the Inspect tool, a target where that point of the image looks.
      const drag = this.drag;
      this.drag = null;
      if (!drag || Math.hypot(e.clientX - drag.x, e.clientY - drag.y) > 4) return;
      const rect = panel.getBoundingClientRect();
      markPov(((e.clientX - rect.left) / rect.width) * 2 - 1, 1 - ((e.clientY - rect.top) / rect.height) * 2);
    });
    on(
      'wheel',
      (e) => {
        e.preventDefault();
        this.look.fov = Math.max(40, Math.min(140, this.look.fov + e.deltaY * 0.05));
      },
      { passive: false },
    );
  }

  /** Robot POV begins: straight ahead, the widest usual view. */
  reset() {
    this.look = { yaw: 0, pitch: 0, fov: 100 };
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
  }
}
