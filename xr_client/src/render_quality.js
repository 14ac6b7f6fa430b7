// @ts-check
/**
 * How well this browser draws, and what the station asks of it. A software renderer (SwiftShader, llvmpipe, the
 * Windows basic display driver: a machine without a usable GPU, a VM, CI) takes 100-300 ms for a frame of the
 * twin; drawn at full quality and every frame it holds the page's main thread and everything behind it (input,
 * the connection). There the station lowers quality by itself: no multisampling, 0.75 resolution, every robot as
 * the fleet's shared shape (level_of_detail.js), and at most SOFTWARE_MAX_FPS drawn frames a second (behaviour
 * keeps running every frame; teleop has its own clock).
 * `?quality=high` overrides; `?quality=low`, `?maxfps=N` and `?detail=N` (robots with their full model at most)
 * force. Pure: the WebGL probe is the caller's.
 */
import { DETAILED_MAX, DETAILED_MAX_LOW_QUALITY } from './level_of_detail.js';

/** Drawn frames a second on a software renderer: enough to follow robots, leaves the main thread for the rest. */
export const SOFTWARE_MAX_FPS = 10;

const SOFTWARE = /swiftshader|llvmpipe|softpipe|software|basic render|microsoft basic|mesa offscreen/i;

/** @param {string | null} renderer the WebGL UNMASKED_RENDERER string (null when the browser hides it) */
export function isSoftwareRenderer(renderer) {
  return renderer !== null && SOFTWARE.test(renderer);
}

/**
 * @param {string | null} renderer @param {URLSearchParams} params
 * @returns {{lowQuality: boolean, maxFps: number | null, software: boolean, reason: string, detailedMax: number}}
 *   maxFps: null, no cap; detailedMax: robots drawn with their full model at most
 */
export function renderQuality(renderer, params) {
  const software = isSoftwareRenderer(renderer);
  const asked = params.get('quality');
  const maxFps = Number(params.get('maxfps')) || (software && asked !== 'high' ? SOFTWARE_MAX_FPS : null);
  const lowQuality = asked === 'low' || (software && asked !== 'high');
  const reason =
    software && asked !== 'high'
      ? `software rendering (${renderer}): lower quality, robots as simple shapes, ${maxFps} frames/s; ` +
        '?quality=high to override'
      : '';
  const detail = Number(params.get('detail'));
  const detailedMax =
    params.has('detail') && Number.isInteger(detail) && detail >= 0
      ? detail
      : lowQuality
        ? DETAILED_MAX_LOW_QUALITY
        : DETAILED_MAX;
  return { lowQuality, maxFps, software, reason, detailedMax };
}
