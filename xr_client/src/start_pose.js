// @ts-check
/**
 * Where the operator stands when VR starts, and which way they face: a spot with room around it and open floor in
 * front, the fleet in view, and the overview table's place free. Pure (no three.js, no DOM): the twin's walls come in
 * as triangles in the map frame, the robots as points; test/start_pose.test.js runs it on the demo facility's glTF.
 *
 * With the robots one per room, the relay's `hello.vantage` (robots in an unbroken line of sight first) started the
 * operator 0.5 m from a blank wall, facing the one robot seen through a door, robot1 88 degrees off the view. Here the
 * fleet in the view comes first: as many robots as one view holds (HALF_FOV either side of the facing), then as many
 * of those in sight, then open floor ahead, then the robots near the middle of the view, then near the operator; and
 * only among spots with ROOM_M of room and the table's place free (when there are any).
 *
 * Cost, measured on the demo facility with 3 robots (node, a 2-core machine under load): ~15 ms, once per entry to
 * VR. At most MAX_SPOTS spots whatever the map, lines of sight for at most MAX_SIGHTED robots (an even sample).
 */

/** A candidate every SPACING metres, or wider on a large map (at most MAX_SPOTS spots). */
export const SPACING = 0.5;
export const MAX_SPOTS = 1500;
/** Room wanted around the spot (m): no wall or obstacle nearer. A spot with less, and at least MIN_ROOM_M, only when
 * no spot of the map has that much. */
export const ROOM_M = 1.0;
export const MIN_ROOM_M = 0.5;
/** No robot nearer than this to the spot (m): the operator does not start inside a robot, nor beside one that moves
 * (and sees it with the others, not under the chin). */
export const NEAR_M = 1.5;
/** No robot nearer the table's centre than its radius and this (m): a robot standing in the table. */
export const TABLE_CLEAR_M = 0.4;
/** Half the horizontal view the fleet should fit in: a Quest 3 shows about 110 degrees; 40 leaves a margin. */
export const HALF_FOV = (40 * Math.PI) / 180;
/** Open floor wanted ahead of the facing (m): not a wall at arm's length. */
export const AHEAD_M = 3;
/** Robots judged for lines of sight at most (an even sample of a larger fleet, by name). */
export const MAX_SIGHTED = 24;
/**
 * Where the overview table stands, from the head: this far (its centre, m) and this angle to the right of the facing
 * (rad), with this radius; view/miniature_view.js places it so. On the right: on the left it stood behind the wrist
 * panel (the left hand's), and straight ahead, low, the menu tab is.
 */
export const TABLE_DISTANCE_M = 0.85;
export const TABLE_BEARING = (-40 * Math.PI) / 180;
export const TABLE_RADIUS_M = 0.5;
/** Heights over the floor at which the walls are taken (m): shins, hips, eyes. */
export const WALL_HEIGHTS_M = Object.freeze([0.25, 1.0, 1.6]);
/** The walls' grid: this fine, or coarser on a large map (at most MAX_CELLS cells). */
export const RESOLUTION = 0.1;
export const MAX_CELLS = 1_500_000;

/** @typedef {[number, number, number, number]} Segment a wall's trace on the floor plan: x1, y1, x2, y2 (map frame) */
/**
 * @typedef {{x0: number, y0: number, resolution: number, width: number, height: number, distance: Float32Array}}
 *   RoomGrid `distance`: metres from each cell's centre to the nearest wall (0 on a wall; the map's edge counts as one)
 * @typedef {{name: string, x: number, y: number}} RobotSpot
 * @typedef {{name?: string, bounds: number[]}} Room a room's bounds: min x, min y, max x, max y
 * @typedef {{x: number, y: number, yaw: number, inView: string[], inSight: string[], room: number, ahead: number,
 *   table: {x: number, y: number}, tableFree: boolean}} StartPose `yaw` counter-clockwise from +x (map frame)
 */

/**
 * Where the walls are at the heights a standing operator meets them: the segments where the twin's triangles cross
 * horizontal planes. Flat things (the floor, a spill) cross none; a thing over the head (a pipe, a lintel) neither.
 * @param {ArrayLike<number>} triangles map-frame vertices, 9 numbers a triangle (x, y, z with z up)
 * @param {readonly number[]} heights the planes' z (map frame)
 * @returns {Segment[]}
 */
export function sliceWalls(triangles, heights) {
  /** @type {Segment[]} */
  const out = [];
  for (let t = 0; t + 8 < triangles.length; t += 9) {
    const zs = [triangles[t + 2], triangles[t + 5], triangles[t + 8]];
    const low = Math.min(...zs);
    const high = Math.max(...zs);
    for (const h of heights) {
      if (h < low || h > high || low === high) continue;
      /** @type {number[]} */
      const points = [];
      for (let e = 0; e < 3; e++) {
        const a = t + e * 3;
        const b = t + ((e + 1) % 3) * 3;
        const za = triangles[a + 2];
        const zb = triangles[b + 2];
        if ((za - h) * (zb - h) > 0 || za === zb) continue;
        const k = (h - za) / (zb - za);
        points.push(
          triangles[a] + (triangles[b] - triangles[a]) * k,
          triangles[a + 1] + (triangles[b + 1] - triangles[a + 1]) * k,
        );
      }
      if (points.length >= 4) out.push([points[0], points[1], points[2], points[3]]);
    }
  }
  return out;
}

/**
 * The floor plan as a grid of distances to the nearest wall: the segments drawn into cells, the map's edge a wall
 * too, then a chamfer distance transform (two passes).
 * @param {Segment[]} segments @param {number[]} bounds min x, min y, max x, max y (map frame)
 * @returns {RoomGrid}
 */
export function roomGrid(segments, bounds) {
  const [minX, minY, maxX, maxY] = bounds;
  const resolution = Math.max(RESOLUTION, Math.sqrt(((maxX - minX) * (maxY - minY)) / MAX_CELLS));
  const width = Math.max(1, Math.ceil((maxX - minX) / resolution));
  const height = Math.max(1, Math.ceil((maxY - minY) / resolution));
  const distance = new Float32Array(width * height).fill(Infinity);
  for (let i = 0; i < width; i++) distance[i] = distance[(height - 1) * width + i] = 0;
  for (let j = 0; j < height; j++) distance[j * width] = distance[j * width + width - 1] = 0;
  for (const [x1, y1, x2, y2] of segments) {
    const steps = Math.max(1, Math.ceil(Math.hypot(x2 - x1, y2 - y1) / (resolution / 2)));
    for (let s = 0; s <= steps; s++) {
      const i = Math.floor((x1 + ((x2 - x1) * s) / steps - minX) / resolution);
      const j = Math.floor((y1 + ((y2 - y1) * s) / steps - minY) / resolution);
      if (i >= 0 && j >= 0 && i < width && j < height) distance[j * width + i] = 0;
    }
  }
  const a = resolution;
  const b = resolution * Math.SQRT2;
  for (let j = 0; j < height; j++) {
    for (let i = 0; i < width; i++) {
      const k = j * width + i;
      let d = distance[k];
      if (i > 0) d = Math.min(d, distance[k - 1] + a);
      if (j > 0) {
        d = Math.min(d, distance[k - width] + a);
        if (i > 0) d = Math.min(d, distance[k - width - 1] + b);
        if (i < width - 1) d = Math.min(d, distance[k - width + 1] + b);
      }
      distance[k] = d;
    }
  }
  for (let j = height - 1; j >= 0; j--) {
    for (let i = width - 1; i >= 0; i--) {
      const k = j * width + i;
      let d = distance[k];
      if (i < width - 1) d = Math.min(d, distance[k + 1] + a);
      if (j < height - 1) {
        d = Math.min(d, distance[k + width] + a);
        if (i < width - 1) d = Math.min(d, distance[k + width + 1] + b);
        if (i > 0) d = Math.min(d, distance[k + width - 1] + b);
      }
      distance[k] = d;
    }
  }
  return { x0: minX, y0: minY, resolution, width, height, distance };
}

/**
 * Room around a point: metres to the nearest wall (0 outside the grid). @param {RoomGrid} grid @param {number} x
 * @param {number} y
 */
export function roomAt(grid, x, y) {
  const i = Math.floor((x - grid.x0) / grid.resolution);
  const j = Math.floor((y - grid.y0) / grid.resolution);
  if (i < 0 || j < 0 || i >= grid.width || j >= grid.height) return 0;
  return grid.distance[j * grid.width + i];
}

/**
 * Whether nothing stands between two points. The last 0.3 m is not looked at: a robot may stand next to a wall.
 * A wall is its cells and their neighbours (a diagonal line cannot slip between two diagonal cells of a thin wall).
 * @param {RoomGrid} grid @param {number} ax @param {number} ay @param {number} bx @param {number} by
 */
export function sightFree(grid, ax, ay, bx, by) {
  const length = Math.hypot(bx - ax, by - ay);
  const reach = Math.max(0, length - 0.3);
  const step = grid.resolution / 2;
  for (let s = 0; s <= reach; s += step) {
    if (roomAt(grid, ax + ((bx - ax) * s) / length, ay + ((by - ay) * s) / length) < grid.resolution * 1.01)
      return false;
  }
  return true;
}

/**
 * Open floor straight ahead of a point, up to `max` (m). @param {RoomGrid} grid @param {number} x @param {number} y
 * @param {number} yaw @param {number} max
 */
export function openAhead(grid, x, y, yaw, max) {
  const step = grid.resolution / 2;
  const [c, s] = [Math.cos(yaw), Math.sin(yaw)];
  for (let d = 0; d <= max; d += step) if (roomAt(grid, x + c * d, y + s * d) < grid.resolution * 1.01) return d;
  return max;
}

/**
 * The facing from a spot that holds the most robots within HALF_FOV either side, then the most of them in sight;
 * the middle of the arc they span.
 * @param {{bearing: number, name: string, sight: () => boolean}[]} robots
 * @returns {{yaw: number, inView: string[], inSight: string[], spread: number}}
 */
function bestFacing(robots) {
  const sorted = [...robots].sort((p, q) => p.bearing - q.bearing || (p.name < q.name ? -1 : 1));
  let best = { yaw: 0, inView: /** @type {string[]} */ ([]), inSight: /** @type {string[]} */ ([]), spread: 0 };
  for (const first of sorted) {
    const inside = sorted.filter((r) => wrap(r.bearing - first.bearing) <= 2 * HALF_FOV);
    if (inside.length < best.inView.length) continue;
    const inSight = inside.filter((r) => r.sight()).map((r) => r.name);
    if (inside.length === best.inView.length && inSight.length <= best.inSight.length) continue;
    const spread = Math.max(...inside.map((r) => wrap(r.bearing - first.bearing)));
    best = {
      yaw: Math.atan2(Math.sin(first.bearing + spread / 2), Math.cos(first.bearing + spread / 2)),
      inView: inside.map((r) => r.name),
      inSight,
      spread,
    };
  }
  return best;
}

/** An angle's turn counter-clockwise from 0, in [0, 2 pi). @param {number} a */
function wrap(a) {
  const t = a % (2 * Math.PI);
  return t < 0 ? t + 2 * Math.PI : t;
}

/**
 * Where to start: see the file's comment for the order of what counts. Deterministic: the same walls and robots
 * give the same pose. Null without a spot to stand on.
 * @param {{grid: RoomGrid, robots: RobotSpot[], rooms?: Room[], floor?: (x: number, y: number) => boolean}} world
 *   `rooms`: spots only inside one (a map's unexplored outside is not a place to start); `floor`: whether a point is
 *   the twin's floor (not a table, a tank, the top of a thick wall)
 * @returns {StartPose | null}
 */
export function startPose(world) {
  const { grid, robots } = world;
  const minX = grid.x0;
  const minY = grid.y0;
  const maxX = grid.x0 + grid.width * grid.resolution;
  const maxY = grid.y0 + grid.height * grid.resolution;
  const spacing = Math.max(SPACING, Math.sqrt(((maxX - minX) * (maxY - minY)) / MAX_SPOTS));
  const names = robots.map((r) => r.name).sort();
  const every = Math.ceil(names.length / MAX_SIGHTED);
  const sighted = new Set(names.filter((_, i) => i % every === 0));
  const rooms = world.rooms?.length ? world.rooms : null;
  /** @type {{key: number[], pose: StartPose} | null} */
  let best = null;
  for (let x = minX + spacing / 2; x < maxX; x += spacing) {
    for (let y = minY + spacing / 2; y < maxY; y += spacing) {
      const room = roomAt(grid, x, y);
      if (room < MIN_ROOM_M) continue;
      if (rooms && !rooms.some((r) => x >= r.bounds[0] && x <= r.bounds[2] && y >= r.bounds[1] && y <= r.bounds[3]))
        continue;
      if (robots.some((r) => Math.hypot(r.x - x, r.y - y) < NEAR_M)) continue;
      if (world.floor && !world.floor(x, y)) continue;
      const facing = bestFacing(
        robots.map((r) => ({
          name: r.name,
          bearing: Math.atan2(r.y - y, r.x - x),
          sight: () => sighted.has(r.name) && sightFree(grid, x, y, r.x, r.y),
        })),
      );
      const yaw = robots.length ? facing.yaw : 0;
      const ahead = openAhead(grid, x, y, yaw, AHEAD_M * 2);
      const table = {
        x: x + TABLE_DISTANCE_M * Math.cos(yaw + TABLE_BEARING),
        y: y + TABLE_DISTANCE_M * Math.sin(yaw + TABLE_BEARING),
      };
      const tableFree =
        roomAt(grid, table.x, table.y) >= TABLE_RADIUS_M &&
        sightFree(grid, x, y, table.x, table.y) &&
        robots.every((r) => Math.hypot(r.x - table.x, r.y - table.y) >= TABLE_RADIUS_M + TABLE_CLEAR_M);
      const inView = robots.filter((r) => facing.inView.includes(r.name));
      const distance = inView.reduce((sum, r) => sum + Math.hypot(r.x - x, r.y - y), 0) / (inView.length || 1);
      // What counts, in order (compared as a tuple; ties keep the first spot found: deterministic).
      const key = [
        room >= ROOM_M && tableFree ? 1 : 0,
        facing.inView.length,
        facing.inSight.length,
        ahead >= AHEAD_M ? 1 : 0,
        -Math.ceil(facing.spread / HALF_FOV), // the robots within 20 degrees of the middle of the view, or within 40
        -Math.round(distance), // then nearer them (by metres: labels fade out past 16 m)
      ];
      if (!best || greater(key, best.key)) {
        best = {
          key,
          pose: { x, y, yaw, inView: facing.inView, inSight: facing.inSight, room, ahead, table, tableFree },
        };
      }
    }
  }
  return best?.pose ?? null;
}

/** @param {number[]} a @param {number[]} b */
function greater(a, b) {
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return a[i] > b[i];
  return false;
}
