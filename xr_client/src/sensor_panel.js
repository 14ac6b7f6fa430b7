// @ts-check
/**
 * What the sensor panels (on the wrist in VR, in the corner on the desktop) show for the selected robot: its
 * status line (with its mission's progress), its readings with their warnings, and the link to the relay. Plain data:
 * the drawing is view/sensor_drawing.js's.
 */

import { formatSilence } from './freshness.js';

/** @typedef {import('./fleet_model.js').FleetModel} FleetModel */
/** @typedef {import('./sensor_history.js').SensorHistory} SensorHistory */

/**
 * What the wrist and corner sensor panels show: the selected robot's readings and the link.
 * @param {FleetModel} fleet @param {string | null} selected @param {SensorHistory} history
 * @param {{text: string, ok: boolean}} link @param {number} now
 * @param {string} [mission] the robot's mission progress ("mission: step 2 of 3 (inspect spill)"), '' for none
 * @param {{freshness: import('./freshness.js').Freshness, linkStale: boolean} | null} [age] what is old: a reading
 *   silent past its usual rate, or everything when the relay went quiet (drawn grey, with its age)
 * @returns {import('./view/sensor_drawing.js').SensorPanelData}
 */
export function sensorPanel(fleet, selected, history, link, now, mission = '', age = null) {
  const entry = fleet.robot(selected);
  const status = entry?.status;
  const goal = status?.goal ? ` → (${status.goal.x.toFixed(1)}, ${status.goal.y.toFixed(1)})` : '';
  return {
    robot: entry?.description.name ?? null,
    colour: entry?.description.colour ?? '#888',
    status: entry
      ? `${status?.estopped ? 'E-STOPPED · ' : ''}${status?.online === false ? 'offline' : (status?.mode ?? '')}` +
        `${goal}${mission ? ` · ${mission}` : ''}`
      : '',
    link: link.text,
    linkOk: link.ok,
    sensors: (entry?.description.sensors ?? []).map((s) => {
      const reading = entry?.sensors.get(s.name);
      const key = `${entry?.description.name}/${s.name}`;
      const silent = age?.freshness.age(key, now) ?? null;
      const old =
        reading !== undefined && age !== null && silent !== null && (age.linkStale || age.freshness.stale(key, now));
      const stale = old ? `${formatSilence(/** @type {number} */ (silent))} ago` : null;
      return {
        name: s.name,
        unit: reading?.unit ?? s.unit,
        value: reading?.value ?? null,
        warning: reading?.warning ?? false,
        stale,
        above: s.warn_above ?? null,
        below: s.warn_below ?? null,
      };
    }),
    history: history,
    now,
  };
}
