// @ts-check
/**
 * What a map shows besides the building, drawn on the twin's floor: each room's name (the relay's
 * `hello.rooms`, from the scene file), a 1 m grid over the map's bounds (the scale, in VR and on the desktop)
 * and a north arrow beside the building. Rebuilt only when the fleet's generation changes (a hello, a new
 * scene), never per frame; the desktop's compass and scale bar are HTML (view/desktop_views.js).
 */
import * as THREE from 'three';
import { mapToScene } from '../frames.js';
import { fitText } from './canvas_text.js';

/** Grid spacing (m). */
export const GRID_STEP = 1;
/** Room names are written this wide at most (m), and at most this share of the room's width. */
const TITLE_MAX = 4.5;
const TITLE_SHARE = 0.8;

export class MapAnnotations {
  constructor() {
    this.group = new THREE.Group();
    this.group.name = 'map-annotations';
    this.generation = -1;
    /** Room titles written on the floor, in the order of hello.rooms. @type {string[]} */
    this.rooms = [];
    /** Grid lines drawn (both directions). */
    this.gridLines = 0;
    this.north = false;
    /** @type {(() => void)[]} */
    this.disposers = [];
  }

  /** Rebuild from the fleet when it was replaced. @param {import('../fleet_model.js').FleetModel} fleet */
  update(fleet) {
    if (fleet.generation === this.generation) return;
    this.generation = fleet.generation;
    this.#clear();
    const t = fleet.scene.mapToScene;
    for (const room of fleet.rooms) this.#room(t, room);
    if (fleet.bounds) {
      this.#grid(t, fleet.bounds);
      this.#north(t, fleet.bounds);
    }
  }

  /** @param {import('../frames.js').MapToScene} t @param {import('../protocol.js').RoomDescription} room */
  #room(t, room) {
    const [x0, y0, x1, y1] = room.bounds;
    const width = Math.min(TITLE_MAX, (x1 - x0) * TITLE_SHARE);
    const canvas = document.createElement('canvas');
    canvas.width = 1024;
    canvas.height = 160;
    const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    ctx.fillStyle = 'rgba(226, 232, 242, 0.78)';
    fitText(ctx, room.title.toUpperCase(), 512, 80, 1000, 104, 700);
    const mesh = this.#flat(canvas, width, (width * canvas.height) / canvas.width, `room:${room.name}`);
    // North of the room's middle: seen over the corridor wall from the usual view (south, above), and clear of
    // the doorway where robots come in.
    const [x, y, z] = mapToScene(t, (x0 + x1) / 2, y0 + (y1 - y0) * 0.62, 0.015);
    mesh.position.set(x, y, z);
    mesh.rotation.y = t.yaw;
    this.rooms.push(room.title);
  }

  /** @param {import('../frames.js').MapToScene} t @param {number[]} bounds */
  #grid(t, bounds) {
    const [x0, y0, x1, y1] = bounds;
    /** @type {number[]} */
    const points = [];
    const line = (
      /** @type {number} */ ax,
      /** @type {number} */ ay,
      /** @type {number} */ bx,
      /** @type {number} */ by,
    ) => {
      points.push(...mapToScene(t, ax, ay, 0.006), ...mapToScene(t, bx, by, 0.006));
      this.gridLines++;
    };
    for (let x = Math.ceil(x0 / GRID_STEP) * GRID_STEP; x <= x1 + 1e-6; x += GRID_STEP) line(x, y0, x, y1);
    for (let y = Math.ceil(y0 / GRID_STEP) * GRID_STEP; y <= y1 + 1e-6; y += GRID_STEP) line(x0, y, x1, y);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.Float32BufferAttribute(points, 3));
    const material = new THREE.LineBasicMaterial({
      color: '#9fb4d6',
      transparent: true,
      opacity: 0.16,
      depthWrite: false,
    });
    const grid = new THREE.LineSegments(geometry, material);
    grid.name = 'map-grid';
    grid.raycast = () => {};
    this.group.add(grid);
    this.disposers.push(() => (geometry.dispose(), material.dispose()));
  }

  /**
   * A north arrow on the ground, outside the building's north-east corner. @param {import('../frames.js').MapToScene} t
   * @param {number[]} bounds
   */
  #north(t, bounds) {
    const canvas = document.createElement('canvas');
    canvas.width = canvas.height = 256;
    const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
    ctx.fillStyle = 'rgba(16, 20, 28, 0.7)';
    ctx.beginPath();
    ctx.arc(128, 128, 124, 0, 2 * Math.PI);
    ctx.fill();
    ctx.fillStyle = '#ff5a5a';
    ctx.beginPath();
    ctx.moveTo(128, 20);
    ctx.lineTo(176, 150);
    ctx.lineTo(128, 126);
    ctx.lineTo(80, 150);
    ctx.closePath();
    ctx.fill();
    ctx.fillStyle = '#fff';
    ctx.textAlign = 'center';
    fitText(ctx, 'N', 128, 196, 120, 64, 800);
    const mesh = this.#flat(canvas, 1.2, 1.2, 'north-arrow');
    const [x, y, z] = mapToScene(t, bounds[2] + 1.2, bounds[3] - 0.8, 0.015);
    mesh.position.set(x, y, z);
    mesh.rotation.y = t.yaw;
    this.north = true;
  }

  /**
   * A canvas lying on the floor, its top edge to the map's north (rotation.y turns it with the map).
   * @param {HTMLCanvasElement} canvas @param {number} width @param {number} height @param {string} name
   */
  #flat(canvas, width, height, name) {
    const texture = new THREE.CanvasTexture(canvas);
    texture.colorSpace = THREE.SRGBColorSpace;
    texture.anisotropy = 4;
    const geometry = new THREE.PlaneGeometry(width, height).rotateX(-Math.PI / 2);
    const material = new THREE.MeshBasicMaterial({
      map: texture,
      transparent: true,
      depthWrite: false,
      polygonOffset: true,
      polygonOffsetFactor: -2,
    });
    const mesh = new THREE.Mesh(geometry, material);
    mesh.name = name;
    mesh.raycast = () => {}; // the floor under it stays what pointing hits
    mesh.renderOrder = 1;
    this.group.add(mesh);
    this.disposers.push(() => (texture.dispose(), geometry.dispose(), material.dispose()));
    return mesh;
  }

  #clear() {
    for (const dispose of this.disposers) dispose();
    this.disposers = [];
    this.group.clear();
    this.rooms = [];
    this.gridLines = 0;
    this.north = false;
  }

  dispose() {
    this.#clear();
    this.group.removeFromParent();
  }
}
