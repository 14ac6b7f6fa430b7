// @ts-check
/**
 * The emulated headset's pace: `?emulate=quest3&xrfps=N` runs the emulator's device frames (IWER drives them from
 * the page's requestAnimationFrame) at most N times a second. A real headset sets its own pace; an emulated one
 * on a machine without a GPU (CI's WebGL is SwiftShader: 100-300 ms a stereo frame) otherwise draws back to back
 * and holds the page's main thread for every frame, so that input, the socket and the tests' own reads queue
 * behind frames. Outside emulation nothing here runs.
 */

/**
 * Replace the page's requestAnimationFrame and cancelAnimationFrame with ones that call back at most `fps` times
 * a second, each call on the display's next frame after its slot.
 * @param {Window} win @param {number} fps
 */
export function paceAnimationFrames(win, fps) {
  const request = win.requestAnimationFrame.bind(win);
  const cancel = win.cancelAnimationFrame.bind(win);
  const interval = 1000 / fps;
  let next = 0;
  let handles = 0;
  /** @type {Map<number, {timer: number | null, frame: number | null}>} */
  const pending = new Map();
  win.requestAnimationFrame = (callback) => {
    const handle = ++handles;
    const now = win.performance.now();
    const wait = Math.max(0, next - now);
    next = Math.max(now, next) + interval;
    const entry = { timer: /** @type {number | null} */ (null), frame: /** @type {number | null} */ (null) };
    pending.set(handle, entry);
    entry.timer = win.setTimeout(() => {
      entry.timer = null;
      entry.frame = request((time) => {
        pending.delete(handle);
        callback(time);
      });
    }, wait);
    return handle;
  };
  win.cancelAnimationFrame = (handle) => {
    const entry = pending.get(handle);
    if (!entry) return;
    pending.delete(handle);
    if (entry.timer !== null) win.clearTimeout(entry.timer);
    if (entry.frame !== null) cancel(entry.frame);
  };
}
