// @ts-check
/**
 * When the station makes a sound or a controller pulse, from what the operator would otherwise have to look for:
 * a sensor crossing its warning level (an earcon at that robot's place, repeated while it stays over), the selected
 * robot's hazard reading as a Geiger-like tick whose rate rises with the reading (when switched on), a goal accepted
 * or refused, an emergency stop. Pure: the page's state is compared with the previous one, time passed in
 * (view/sound_control.js polls it; test/cue_rules.test.js). A lease lost to another operator is a cue too, from the
 * relay's lease event (control_news.js), which a comparison every 100 ms could miss.
 */

/** A warning repeats this often while its sensor stays over its level (ms). */
export const WARNING_REPEAT_MS = 4000;
/** Hazard ticks: one a second at no reading, up to 15 a second at twice the warning level. */
export const TICK_SLOWEST_MS = 1000;
export const TICK_FASTEST_MS = 67;
/** A warning pulses the controllers only when its robot is this close to the selected one or is it (m). */
export const HAPTIC_NEAR_M = 5;

/**
 * @typedef {'warning' | 'goal_accepted' | 'goal_refused' | 'lease_lost' | 'estop'} CueKind
 * @typedef {{kind: CueKind, robot: string | null}} Cue
 * @typedef {{name: string, x: number, y: number, warnings: string[], goal: string | null, latched: boolean}} RobotView
 *   the state of one robot as the rules read it: its sensors over their levels, its goal's state ('pending',
 *   'active', 'error' or null)
 */

/**
 * The interval between hazard ticks for a reading against its warning level (ms): faster as it rises.
 * @param {number} value @param {number} level the warning level (> 0)
 */
export function tickInterval(value, level) {
  if (!(level > 0) || !Number.isFinite(value)) return TICK_SLOWEST_MS;
  const share = Math.min(2, Math.max(0, value / level)); // 0 .. 2x the level
  // Rate grows geometrically with the share (a Geiger counter's clicks), 1/s at zero to 15/s at twice the level.
  const rate = Math.pow(15, share / 2);
  return Math.max(TICK_FASTEST_MS, Math.min(TICK_SLOWEST_MS, Math.round(1000 / rate)));
}

export class CueRules {
  /** @type {Map<string, RobotView>} the previous state */
  last = new Map();
  /** Warnings sounding, by robot/sensor: when they last sounded. @type {Map<string, number>} */
  warned = new Map();
  /** The next hazard tick (ms), or null when the sonification is off. @type {number | null} */
  nextTick = null;

  /**
   * Compare the page's state with the previous one. @param {RobotView[]} robots @param {number} now ms
   * @returns {Cue[]}
   */
  update(robots, now) {
    /** @type {Cue[]} */
    const cues = [];
    const seen = new Set();
    for (const robot of robots) {
      const before = this.last.get(robot.name);
      for (const sensor of robot.warnings) {
        const key = `${robot.name}/${sensor}`;
        seen.add(key);
        const at = this.warned.get(key);
        if (at === undefined || now - at >= WARNING_REPEAT_MS) {
          cues.push({ kind: 'warning', robot: robot.name });
          this.warned.set(key, now);
        }
      }
      if (before) {
        if (before.goal === 'pending' && robot.goal === 'active')
          cues.push({ kind: 'goal_accepted', robot: robot.name });
        if (before.goal !== 'error' && robot.goal === 'error') cues.push({ kind: 'goal_refused', robot: robot.name });
        if (!before.latched && robot.latched) cues.push({ kind: 'estop', robot: robot.name });
      }
      this.last.set(robot.name, robot);
    }
    for (const key of [...this.warned.keys()]) if (!seen.has(key)) this.warned.delete(key); // back under: quiet
    // One estop earcon for a fleet-wide stop, not one per robot.
    const estops = cues.filter((c) => c.kind === 'estop');
    if (estops.length > 1) return [...cues.filter((c) => c.kind !== 'estop'), { kind: 'estop', robot: null }];
    return cues;
  }

  /**
   * Whether a hazard tick is due now (the sonification on, for a reading and its level). @param {number} value
   * @param {number} level @param {number} now @returns {boolean}
   */
  tick(value, level, now) {
    if (this.nextTick === null || now >= this.nextTick) {
      this.nextTick = now + tickInterval(value, level);
      return true;
    }
    return false;
  }

  /** The sonification switched off: the next one starts at once. */
  stopTicks() {
    this.nextTick = null;
  }
}

/**
 * The controller pulse for a cue (null: none): warnings only near the selected robot, the rest always.
 * @param {Cue} cue
 * @param {{selected: {x: number, y: number, name: string} | null, at: {x: number, y: number} | null}} where
 * @returns {{intensity: number, ms: number, pulses: number} | null}
 */
export function hapticFor(cue, where) {
  switch (cue.kind) {
    case 'estop':
      return { intensity: 1.0, ms: 120, pulses: 3 };
    case 'lease_lost':
      return { intensity: 0.8, ms: 80, pulses: 2 };
    case 'goal_refused':
      return { intensity: 0.6, ms: 60, pulses: 2 };
    case 'goal_accepted':
      return null; // heard, not felt: good news needs no nudge
    case 'warning': {
      const { selected, at } = where;
      if (!selected || !at) return null;
      const near = cue.robot === selected.name || Math.hypot(at.x - selected.x, at.y - selected.y) <= HAPTIC_NEAR_M;
      return near ? { intensity: 0.5, ms: 50, pulses: 1 } : null;
    }
  }
}
