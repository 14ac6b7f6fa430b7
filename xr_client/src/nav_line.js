// @ts-check
/**
 * What a robot's label says of its navigation, from the latest `<robot>/nav` (docs/protocol.md): Nav2's feedback
 * while the goal runs, then how it ended, for a while. Pure (test/nav_line.test.js); the fleet view draws it as the
 * label's third line, nothing when there is nothing to say.
 */

/** How long an outcome stays on the label (ms): long enough to be read from across the site, short enough that the
 * label is the robot's name and mode again before its next goal. */
export const OUTCOME_MS = 10_000;

/** @param {number} seconds */
export function formatEta(seconds) {
  if (!(seconds >= 0)) return '?';
  if (seconds < 60) return `${Math.round(seconds)} s`;
  return `${Math.floor(seconds / 60)} min ${String(Math.round(seconds % 60)).padStart(2, '0')} s`;
}

/**
 * @param {{message: import('./protocol.js').NavMessage, at: number} | null | undefined} nav the latest `<robot>/nav`
 *   and when it came (page ms)
 * @param {string | undefined} mode the robot's status mode now
 * @param {number} now page ms
 * @returns {string}
 */
export function navLine(nav, mode, now) {
  if (!nav) return '';
  const { message, at } = nav;
  if (message.outcome === 'started') {
    const f = message.feedback;
    // Feedback is news only while the robot still follows that goal (the status says whether it does).
    if (!f || mode !== 'navigating') return '';
    const recoveries = f.recoveries > 0 ? ` · ${f.recoveries} recover${f.recoveries === 1 ? 'y' : 'ies'}` : '';
    const remaining = f.distance_remaining >= 0 ? `${f.distance_remaining.toFixed(1)} m` : '? m';
    return `${remaining} · ${formatEta(f.eta)} left${recoveries}`;
  }
  if (now - at > OUTCOME_MS) return '';
  if (message.outcome === 'reached') return 'goal reached';
  if (message.outcome === 'failed') return `aborted${message.error_code ? ` (Nav2 error ${message.error_code})` : ''}`;
  if (message.confirmed === true) return 'cancelled · Nav2 confirmed';
  if (message.confirmed === false) return 'cancelled · Nav2 did not confirm';
  return 'cancelled';
}
