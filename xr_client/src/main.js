// @ts-check
/**
 * Bootstrap: the page's only script. With `?emulate=quest3` (or quest2, questpro) in the address it first
 * installs the IWER headset emulator (served from /node_modules/iwer) in place of any WebXR runtime, so a
 * developer without a headset, and the end-to-end tests, can enter VR and drive emulated controllers
 * (the emulated device is `window.__iwer`). Then it waits for the local font (canvas-drawn labels need
 * it loaded) and starts the application. `?maxfps=N` draws at most N frames a second (input, teleop and
 * the connection keep their own pace): for software-rendered browsers such as CI's. `window.__xrRelay.state` is a
 * read-only snapshot of the client's state for tests and debugging.
 */

export {}; // a module: top-level await below

const params = new URLSearchParams(window.location.search);
const emulate = params.get('emulate');
if (emulate) {
  const iwer = await import('iwer');
  const configs = { quest3: iwer.metaQuest3, quest2: iwer.metaQuest2, questpro: iwer.metaQuestPro };
  const config = configs[/** @type {keyof typeof configs} */ (emulate)];
  if (!config) {
    console.warn(`?emulate=${emulate}: unknown device; use one of ${Object.keys(configs).join(', ')}`);
  } else {
    const pace = Number(params.get('xrfps'));
    if (pace > 0) (await import('./emulator_pace.js')).paceAnimationFrames(window, pace);
    const device = new iwer.XRDevice(config);
    // Chromium already defines navigator.xr on localhost: replace it.
    device.installRuntime({ forceInstall: true });
    /** @type {any} */ (window).__iwer = device;
  }
}

await Promise.race([
  Promise.all([document.fonts.load('500 16px Inter'), document.fonts.load('700 16px Inter')]),
  new Promise((resolve) => setTimeout(resolve, 2000)),
]);

const { App } = await import('./app.js');
const { mapToScene } = await import('./frames.js');
const { mapToPage } = await import('./view/state_snapshot.js');
const { renderQuality } = await import('./render_quality.js');
const container = /** @type {HTMLElement} */ (document.getElementById('viewport'));
// ?maxfps=N caps the drawing rate (a laptop on battery); ?quality=low: no multisampling, a lower resolution. A
// software renderer gets both by itself (render_quality.js), unless ?quality=high.
const quality = renderQuality(webglRenderer(), params);
const app = new App(container, {
  maxFps: quality.maxFps ?? undefined,
  lowQuality: quality.lowQuality,
  detailedMax: quality.detailedMax,
});
app.start();
const { AccountFlow } = await import('./station/account_flow.js');
const accounts = new AccountFlow(
  {
    connection: app.connection,
    operatorUi: app.views.operatorUi,
    notify: (/** @type {string} */ text) => app.views.notify(text, 'error'),
  },
  document,
  window.location.origin,
);
void accounts.start();
if (quality.reason) {
  console.info(quality.reason);
  app.views.overlay.say(quality.reason, 'info', 8000);
}
/** @type {any} */ (window).__xrRelay = Object.freeze({
  get state() {
    return app.testState();
  },
  /** @param {number} x @param {number} y @param {number} [z] map point -> page pixels */
  mapToPage: (x, y, z) => mapToPage(app, x, y, z),
  /** @param {number} x @param {number} y @param {number} [z] map point -> scene (glTF) point */
  mapToScene: (x, y, z) => mapToScene(app.fleet.scene.mapToScene, x, y, z),
  /** @param {number} x @param {number} y map point -> where it is on VR's overview table (world) */
  overviewPoint: (x, y) => app.views.hud.miniature.worldPoint(x, y, app.fleet.scene.mapToScene),
  /**
   * @param {[number, number] | null} [pixel] the VR finding card's buttons (and a pixel of its capture) -> scene points
   */
  cardPoints: (pixel) => app.views.findingCard.points(pixel ?? null),
  /**
   * The last n camera pictures decoded: [publisher stamp (s), page time (ms)] pairs (picture_times.js).
   * @param {number} n
   */
  pictureTimes: (n) => app.views.feed.times.recent(n),
  /** How this browser draws and what the station asks of it (render_quality.js). */
  quality,
  version: 1,
});

/** The WebGL renderer's name (a GPU's, or SwiftShader's), or null when the browser will not say. */
function webglRenderer() {
  try {
    const gl =
      document.createElement('canvas').getContext('webgl2') ?? document.createElement('canvas').getContext('webgl');
    if (!gl) return null;
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    gl.getExtension('WEBGL_lose_context')?.loseContext(); // one probe context, released at once
    return name;
  } catch {
    return null;
  }
}
