// @ts-check
/** The VR finding card's trend: the reading over its last rounds (view/finding_card.js draws the rest). */
import { fillRounded, fitText } from './canvas_text.js';
import { sparkline } from '../sparkline.js';

/**
 * The reading over its last rounds in ``box``: a line through a dot a round, the threshold dashed and labelled,
 * and a caption (the geometry is sparkline.js, as on the desktop card).
 * @param {CanvasRenderingContext2D} ctx @param {{x: number, y: number, w: number, h: number}} box
 * @param {import('../protocol.js').TrendDescription} trend
 */
export function drawTrend(ctx, box, trend) {
  const caption = 26;
  const line = sparkline(trend.points, trend.threshold, { width: box.w, height: box.h - caption, pad: 8 });
  const unit = trend.unit ? ` ${trend.unit}` : '';
  ctx.save();
  ctx.translate(box.x, box.y);
  fillRounded(ctx, [0, 0, box.w, box.h - caption], 10, 'rgba(255,255,255,0.05)');
  if (line.limit !== null && trend.threshold !== null) {
    ctx.strokeStyle = '#ff6b5e';
    ctx.lineWidth = 2;
    ctx.setLineDash([10, 7]);
    ctx.beginPath();
    ctx.moveTo(8, line.limit);
    ctx.lineTo(box.w - 8, line.limit);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = '#ff6b5e';
    const above = line.limit > (box.h - caption) / 2;
    fitText(ctx, `${trend.threshold}${unit}`, 12, line.limit + (above ? -12 : 14), box.w / 2, 18);
  }
  ctx.strokeStyle = '#8ab4ff';
  ctx.fillStyle = '#8ab4ff';
  ctx.lineWidth = 3;
  ctx.beginPath();
  line.points.forEach((p, i) => (i === 0 ? ctx.moveTo(p.x, p.y) : ctx.lineTo(p.x, p.y)));
  ctx.stroke();
  for (const p of line.points) {
    ctx.beginPath();
    ctx.arc(p.x, p.y, 5, 0, Math.PI * 2);
    ctx.fill();
  }
  ctx.fillStyle = '#9aa5b8';
  const rounds = trend.points.length;
  const latest = trend.points[rounds - 1][1];
  const said = `${trend.sensor} over ${rounds} round${rounds === 1 ? '' : 's'}: now ${latest.toFixed(1)}${unit}`;
  fitText(ctx, said, 0, box.h - caption / 2, box.w, 20);
  ctx.restore();
}
