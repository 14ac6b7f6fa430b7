// @ts-check
/**
 * The words the panels show, built from the app's state each time they redraw: the sensor panels' data (the
 * selected robot, its readings and their age, the link, with how long the relay has been silent, how late its pose,
 * picture and commands come) and the Robot POV panel's caption (with the picture's latency). Building them changes
 * nothing.
 */
import { sensorPanel } from '../sensor_panel.js';
import { formatSilence } from '../freshness.js';
import { formatMs, latencyParts } from '../latency.js';

/** What the wrist and corner sensor panels show. @param {import('../app.js').App} app @param {number} now */
export function sensorPanelData(app, now) {
  const age = { freshness: app.router.freshness, linkStale: app.router.linkStale(app.relay.linkOk, now) };
  // An open socket that brings nothing is not a working link: say how long the relay has been silent.
  const quiet =
    age.linkStale && app.relay.linkOk ? ` · no answer for ${formatSilence(now - app.router.lastMessage)}` : '';
  const link = { text: app.relay.linkText + quiet, ok: app.relay.linkOk && !quiet };
  const panel = sensorPanel(
    app.fleet,
    app.menu.selected,
    app.history,
    link,
    now,
    app.views.inspectionUi.progress(app.menu.selected),
    age,
  );
  // How late this robot's pose, picture and commands are, each in its colour (latency.js).
  return { ...panel, latency: app.menu.selected ? latencyParts(app.latency.of(app.menu.selected)) : [] };
}

/** The POV panel's caption. @param {import('../app.js').App} app */
export function povCaption(app) {
  const s = app.views.hemisphere;
  const robot = app.menu.selected ?? '–';
  const live = app.menu.live ? 'live' : 'snapshot';
  const late = app.menu.selected ? app.latency.of(app.menu.selected).picture : null;
  return s.lastIdentifier
    ? `${robot} · ${live} · frame ${s.lastSeq}${late === null ? '' : ` · picture ${formatMs(late)}`}`
    : `${robot} · ${app.sender.noImageYet ? 'no image yet (no_camera)' : 'waiting for an image'}`;
}
