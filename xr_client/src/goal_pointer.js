// @ts-check
/**
 * The goal pointer as a state machine, in map coordinates (ROS, metres): aim, press to set the position,
 * drag to set the heading, release to send. And the per-robot goal display: pending until the relay
 * answers, then the relay's `status.goal` until it becomes null (reached or cancelled); an `error`
 * (out_of_bounds, no_path, leased, ...) stays beside the marker for a few seconds.
 */

/** A drag shorter than this sets no heading (the robot keeps its own). */
export const MIN_HEADING_DRAG = 0.3;
/** How long an error stays next to the marker, ms. */
export const ERROR_VISIBLE_MS = 6000;

/** @typedef {{x: number, y: number}} MapPoint */
/** @typedef {import('./protocol.js').GoalDescription} Goal the shape the relay reports goals in (status.goal) */

export class GoalPointer {
  constructor() {
    /** @type {'idle' | 'aiming' | 'placing'} */
    this.state = 'idle';
    /** @type {MapPoint | null} where the pointer meets the floor now */
    this.hover = null;
    /** @type {MapPoint | null} the position fixed by the press */
    this.anchor = null;
    /** @type {number | null} */
    this.yaw = null;
    /** What a press would do at the hover point. @type {import('./goal_verdict.js').GoalVerdict | null} */
    this.verdict = null;
  }

  /**
   * Where the pointer meets the twin this frame (null: nothing), and what a press there would do (goal_verdict.js;
   * without one, every hit is floor and a press places a goal). A press places a goal only where the verdict is
   * `goal`; while placing, the hit only turns the heading.
   * @param {MapPoint | null} hit @param {import('./goal_verdict.js').GoalVerdict | null} [verdict]
   */
  aim(hit, verdict = null) {
    this.hover = hit;
    this.verdict = hit ? verdict : null;
    if (this.state === 'placing') {
      if (hit && this.anchor) {
        const dx = hit.x - this.anchor.x;
        const dy = hit.y - this.anchor.y;
        this.yaw = Math.hypot(dx, dy) >= MIN_HEADING_DRAG ? Math.atan2(dy, dx) : null;
      }
    } else {
      this.state = hit ? 'aiming' : 'idle';
    }
  }

  /** Trigger or mouse down. @returns {boolean} whether the press started a goal */
  press() {
    if (this.state !== 'aiming' || !this.hover) return false;
    if (this.verdict && this.verdict.kind !== 'goal') return false;
    this.anchor = { ...this.hover };
    this.yaw = null;
    this.state = 'placing';
    return true;
  }

  /** Trigger or mouse up: the goal to send, from the pressed hit point (never the operator's position). */
  release() {
    if (this.state !== 'placing' || !this.anchor) return null;
    /** @type {Goal} */
    const goal = { x: this.anchor.x, y: this.anchor.y, yaw: this.yaw };
    this.cancel();
    return goal;
  }

  cancel() {
    this.anchor = null;
    this.yaw = null;
    this.state = this.hover ? 'aiming' : 'idle';
  }

  /** The marker the view draws under the pointer: the anchor while placing, else the hover point. */
  get marker() {
    if (this.state === 'placing' && this.anchor) return { ...this.anchor, yaw: this.yaw };
    if (this.state === 'aiming' && this.hover) return { ...this.hover, yaw: null };
    return null;
  }
}

/**
 * @typedef {{goal: Goal, state: 'pending' | 'active' | 'error', id: string | null,
 *   error: {code: string, message: string} | null, since: number}} GoalDisplay
 */

export class GoalTracker {
  constructor() {
    /** @type {Map<string, GoalDisplay>} */
    this.goals = new Map();
  }

  /**
   * A goal went out with this command id. @param {string} robot @param {Goal} goal @param {string} id
   * @param {number} now
   */
  sent(robot, goal, id, now) {
    this.goals.set(robot, { goal, state: 'pending', id, error: null, since: now });
  }

  /** @param {string} id */
  acked(id) {
    for (const display of this.goals.values()) {
      if (display.id === id && display.state === 'pending') display.state = 'active';
    }
  }

  /** @param {string | null} id @param {string} code @param {string} message @param {number} now */
  failed(id, code, message, now) {
    for (const display of this.goals.values()) {
      if (id !== null && display.id === id) {
        display.state = 'error';
        display.error = { code, message };
        display.since = now;
        return true;
      }
    }
    return false;
  }

  /**
   * The relay's status of a robot: its `goal` is the truth once the command was answered.
   * @param {string} robot @param {Goal | null} goal @param {number} now
   */
  status(robot, goal, now) {
    const display = this.goals.get(robot);
    if (display && (display.state === 'pending' || display.state === 'error')) return;
    if (goal)
      this.goals.set(robot, {
        goal: { x: goal.x, y: goal.y, yaw: goal.yaw ?? null },
        state: 'active',
        id: display?.id ?? null,
        error: null,
        since: now,
      });
    else this.goals.delete(robot);
  }

  /** What to draw for a robot now (errors fade after ERROR_VISIBLE_MS). @param {string} robot @param {number} now */
  display(robot, now) {
    const display = this.goals.get(robot);
    if (display?.state === 'error' && now - display.since > ERROR_VISIBLE_MS) {
      this.goals.delete(robot);
      return null;
    }
    return display ?? null;
  }

  /** Forget what the relay has not confirmed (a reconnect: `hello` brings the truth). */
  reset() {
    this.goals.clear();
  }
}
