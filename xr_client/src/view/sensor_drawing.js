// @ts-check
/**
 * Draws the sensor panel (selected robot, each sensor's name, value, unit, a sparkline of the last minute,
 * a red WARNING) into a 2D canvas. The VR wrist panel and the desktop corner panel both use it.
 */
import { fitText, font, roundRect, warningIcon } from './canvas_text.js';

/**
 * @typedef {{robot: string | null, colour: string, status: string, link: string, linkOk: boolean,
 *   sensors: {name: string, value: number | null, unit: string, warning: boolean, stale?: string | null,
 *     above?: number | null, below?: number | null}[],
 *   history: import('../sensor_history.js').SensorHistory, now: number,
 *   latency?: {stage: string, text: string, colour: string}[]}} SensorPanelData
 */

/**
 * @param {CanvasRenderingContext2D} ctx @param {number} width @param {number} height
 * @param {SensorPanelData} data
 */
export function drawSensorPanel(ctx, width, height, data) {
  const u = width / 512; // layout unit: the panel is designed 512 wide
  ctx.clearRect(0, 0, width, height);
  roundRect(ctx, 2 * u, 2 * u, width - 4 * u, height - 4 * u, 18 * u);
  ctx.fillStyle = 'rgba(14,18,26,0.92)';
  ctx.fill();
  ctx.textBaseline = 'middle';
  ctx.textAlign = 'left';
  // Link status: always visible.
  ctx.fillStyle = data.linkOk ? '#5ad17a' : '#ffb020';
  ctx.beginPath();
  ctx.arc(24 * u, 26 * u, 7 * u, 0, 2 * Math.PI);
  ctx.fill();
  ctx.fillStyle = '#c8d0dc';
  fitText(ctx, data.link, 40 * u, 27 * u, width - 56 * u, 20 * u);
  ctx.fillStyle = data.robot ? data.colour : '#8892a6';
  ctx.fillRect(16 * u, 50 * u, 6 * u, 34 * u);
  ctx.fillStyle = '#fff';
  fitText(ctx, data.robot ?? 'no robot selected', 32 * u, 60 * u, width - 48 * u, 28 * u, 700);
  ctx.fillStyle = '#9aa5b8';
  fitText(ctx, data.status, 32 * u, 84 * u, width - 48 * u, 18 * u);
  // How late the pose, the picture and the commands are, each figure in its colour (latency.js).
  const late = data.latency ?? [];
  let x = 32 * u;
  for (const part of late) {
    ctx.fillStyle = part.colour;
    fitText(ctx, part.text, x, 106 * u, width - 16 * u - x, 18 * u, 600);
    x += ctx.measureText(part.text).width + 14 * u;
  }
  const top = (late.length > 0 ? 122 : 102) * u;
  const rows = Math.max(1, data.sensors.length);
  const rowHeight = Math.min(90 * u, (height - top - 8 * u) / rows);
  data.sensors.forEach((s, i) => {
    const y = top + i * rowHeight;
    if (s.warning) {
      roundRect(ctx, 10 * u, y + 2 * u, width - 20 * u, rowHeight - 4 * u, 10 * u);
      ctx.fillStyle = 'rgba(224,36,36,0.22)';
      ctx.fill();
    }
    ctx.fillStyle = '#c8d0dc';
    fitText(ctx, s.name, 20 * u, y + rowHeight * 0.3, 150 * u, 20 * u);
    // An old reading is grey with its age: never drawn as if it were live.
    ctx.fillStyle = s.stale ? '#7a8294' : s.warning ? '#ff6b6b' : '#fff';
    const value = s.value === null ? '–' : formatValue(s.value);
    fitText(ctx, `${value} ${s.unit}`, 20 * u, y + rowHeight * 0.68, 170 * u, 26 * u, 700);
    if (s.stale) {
      ctx.fillStyle = '#ffb020';
      fitText(ctx, `no reading · ${s.stale}`, 222 * u, y + rowHeight * 0.3, 160 * u, 15 * u, 600);
    }
    if (s.warning && !s.stale) {
      warningIcon(ctx, 205 * u, y + rowHeight * 0.3, 22 * u);
      ctx.textAlign = 'left';
      ctx.textBaseline = 'middle';
      ctx.fillStyle = '#ff6b6b';
      fitText(ctx, 'WARNING', 222 * u, y + rowHeight * 0.3, 90 * u, 16 * u, 800);
    }
    // Sparkline of the last minute.
    const sx = 220 * u;
    const sw = width - sx - 20 * u;
    const sh = rowHeight * 0.4;
    const sy = y + rowHeight * 0.45;
    if (data.robot) {
      const { points, min, max, breaks, lines } = data.history.sparkline(data.robot, s.name, data.now, sw, sh, {
        above: s.above,
        below: s.below,
      });
      // The warning threshold, dashed: how far the reading is from it is what the operator reads.
      ctx.strokeStyle = 'rgba(255,107,107,0.7)';
      ctx.lineWidth = 1.5 * u;
      ctx.setLineDash([5 * u, 4 * u]);
      for (const ly of lines) {
        ctx.beginPath();
        ctx.moveTo(sx, sy + ly);
        ctx.lineTo(sx + sw, sy + ly);
        ctx.stroke();
      }
      ctx.setLineDash([]);
      ctx.strokeStyle = s.stale ? '#7a8294' : s.warning ? '#ff6b6b' : '#7fd3ff';
      ctx.lineWidth = 2.5 * u;
      ctx.beginPath();
      // A gap in the data is a gap in the line, never a straight stroke across it.
      points.forEach(([px, py], k) =>
        k === 0 || breaks.includes(k) ? ctx.moveTo(sx + px, sy + py) : ctx.lineTo(sx + px, sy + py),
      );
      ctx.stroke();
      if (points.length) {
        ctx.fillStyle = '#6f7a8e';
        ctx.font = font(12 * u);
        ctx.textAlign = 'right';
        ctx.fillText(`${formatValue(max)}`, width - 20 * u, y + rowHeight * 0.3);
        ctx.fillText(`${formatValue(min)} · 1 min`, sx + sw, sy + sh + 10 * u);
        ctx.textAlign = 'left';
      }
    }
  });
  if (data.sensors.length === 0) {
    ctx.fillStyle = '#8892a6';
    fitText(
      ctx,
      data.robot ? 'this robot has no sensors' : 'select a robot in the menu',
      20 * u,
      top + 30 * u,
      width - 40 * u,
      20 * u,
    );
  }
}

/** @param {number} v */
export function formatValue(v) {
  const a = Math.abs(v);
  return a >= 100 ? v.toFixed(0) : a >= 10 ? v.toFixed(1) : v.toFixed(2);
}
