// @ts-check
/**
 * What the sensor panels (on the wrist in VR, in the corner on the desktop) show for the selected robot: its
 * status line (with its mission's progress), its readings with their warnings, and the link to the relay. Plain data: the drawing is
 * view/sensor_drawing.js's.
 */

/** @typedef {import('./fleet_model.js').FleetModel} FleetModel */
/** @typedef {import('./sensor_history.js').SensorHistory} SensorHistory */

/**
 * What the wrist and corner sensor panels show: the selected robot's readings and the link.
 * @param {FleetModel} fleet @param {string | null} selected @param {SensorHistory} history
 * @param {{text: string, ok: boolean}} link @param {number} now
 * @param {string} [mission] the robot's mission progress ("mission: step 2 of 3 (inspect spill)"), '' for none
 * @returns {import('./view/sensor_drawing.js').SensorPanelData}
 */
export function sensorPanel(fleet, selected, history, link, now, mission = '') {
  const entry = fleet.robot(selected);
  const status = entry?.status;
  return {
    robot: entry?.description.name ?? null,
    colour: entry?.description.colour ?? '#888',
    status: entry ? `${status?.estopped ? 'E-STOPPED · ' : ''}${status?.online === false ? 'offline' : (status?.mode ?? '')}${status?.goal ? ` → (${status.goal.x.toFixed(1)}, ${status.goal.y.toFixed(1)})` : ''}${mission ? ` · ${mission}` : ''}` : '',
    link: link.text,
    linkOk: link.ok,
    sensors: (entry?.description.sensors ?? []).map((s) => {
      const reading = entry?.sensors.get(s.name);
      return { name: s.name, unit: reading?.unit ?? s.unit, value: reading?.value ?? null, warning: reading?.warning ?? false };
    }),
    history: history,
    now,
  };
}
