// @ts-check
/** The minimal operator page: fleet table, top-down map, click-to-goal, emergency stop. */
import { RelayConnection, relayUrl } from './connection.js';
import { FleetModel } from './fleet_model.js';

const model = new FleetModel();
const connection = new RelayConnection(relayUrl(window.location));
/** @type {string | null} */
let selected = null;

const el = (/** @type {string} */ id) => /** @type {HTMLElement} */ (document.getElementById(id));
const canvas = /** @type {HTMLCanvasElement} */ (el('map'));
const context = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));

/** @param {string} text */
function say(text) {
  el('message').textContent = text;
}

function mapTransform() {
  const [minX, minY, maxX, maxY] = model.bounds ?? [-10, -10, 10, 10];
  const scale = Math.min(canvas.width / (maxX - minX), canvas.height / (maxY - minY));
  return {
    toCanvas: (/** @type {number} */ x, /** @type {number} */ y) => [(x - minX) * scale, canvas.height - (y - minY) * scale],
    toMap: (/** @type {number} */ cx, /** @type {number} */ cy) => [cx / scale + minX, (canvas.height - cy) / scale + minY],
    scale,
  };
}

function renderTable() {
  const body = /** @type {HTMLTableSectionElement} */ (el('fleet').querySelector('tbody'));
  body.replaceChildren();
  for (const [name, robot] of model.robots) {
    const row = document.createElement('tr');
    row.dataset.robot = name;
    if (name === selected) row.classList.add('selected');
    const pose = robot.pose ? `${robot.pose.x.toFixed(2)}, ${robot.pose.y.toFixed(2)}, ${robot.pose.yaw.toFixed(2)}` : '–';
    const sensors = [...robot.sensors.values()].map((s) =>
      `<span class="${s.warning ? 'warning' : ''}">${s.name} ${s.value.toFixed(1)} ${s.unit}${s.warning ? ' WARNING' : ''}</span>`).join('<br>');
    const status = robot.status;
    row.innerHTML = `<td><span class="swatch" style="background:${robot.description.colour}"></span></td>` +
      `<td>${name}</td><td>${status?.online ? 'yes' : `no${status?.age != null ? ` (${status.age.toFixed(0)} s)` : ''}`}</td>` +
      `<td>${status?.mode ?? '–'}</td><td>${pose}</td><td>${sensors}</td>`;
    row.addEventListener('click', () => { selected = selected === name ? null : name; renderTable(); });
    body.append(row);
  }
}

function renderMap() {
  const { toCanvas, scale } = mapTransform();
  context.clearRect(0, 0, canvas.width, canvas.height);
  for (const [name, robot] of model.robots) {
    if (!robot.pose) continue;
    const [cx, cy] = toCanvas(robot.pose.x, robot.pose.y);
    context.globalAlpha = robot.status?.online ? 1 : 0.35;
    context.fillStyle = robot.description.colour;
    context.beginPath();
    context.arc(cx, cy, Math.max(4, 0.25 * scale), 0, 2 * Math.PI);
    context.fill();
    context.strokeStyle = name === selected ? '#fff' : robot.description.colour;
    context.beginPath();
    context.moveTo(cx, cy);
    context.lineTo(cx + Math.cos(robot.pose.yaw) * 0.6 * scale, cy - Math.sin(robot.pose.yaw) * 0.6 * scale);
    context.stroke();
    context.fillText(name, cx + 8, cy - 8);
    const goal = robot.status?.goal;
    if (goal) {
      const [gx, gy] = toCanvas(goal.x, goal.y);
      context.strokeRect(gx - 4, gy - 4, 8, 8);
    }
  }
  context.globalAlpha = 1;
}

connection.addEventListener('message', (event) => {
  const message = /** @type {CustomEvent} */ (event).detail;
  if (message.identifier === 'error') say(`error ${message.code}: ${message.message}`);
  else if (message.identifier === 'estop') say(`EMERGENCY STOP: ${message.robots.join(', ')}`);
  else if (model.apply(message) && !message.identifier.endsWith('/pose')) renderTable();
});
connection.addEventListener('status', (event) => {
  const { connected, retryIn } = /** @type {CustomEvent} */ (event).detail;
  const status = el('connection');
  status.textContent = connected ? 'connected' : `disconnected, retrying in ${retryIn} s`;
  status.className = `status ${connected ? 'ok' : 'bad'}`;
});
canvas.addEventListener('click', (event) => {
  if (!selected) { say('select a robot first'); return; }
  const [x, y] = mapTransform().toMap(event.offsetX, event.offsetY);
  const id = connection.send({ identifier: `${selected}/goal_pose`, x, y });
  say(id ? `goal (${x.toFixed(2)}, ${y.toFixed(2)}) sent to ${selected}` : 'not connected: goal not sent');
});
el('estop').addEventListener('click', () => {
  if (!connection.send({ identifier: 'estop' })) say('not connected: E-STOP not delivered!');
});

function frame() {
  renderMap();
  requestAnimationFrame(frame);
}
setInterval(renderTable, 500);
connection.connect();
requestAnimationFrame(frame);
