// @ts-check
/**
 * How big a robot's label is drawn and how opaque, from the viewer's distance: the rule the fleet view applies to
 * every label every frame, kept pure so that a unit test pins it (test/label_rule.test.js).
 *
 * Size: about the same size on screen (LABEL_ANGLE), within LABEL_MIN..LABEL_MAX metres. Opacity: full up to
 * FADE_START, gone at FADE_END. The facility is 18 x 10 m: from the operator's usual place (south of the corridor,
 * eyes at 1.6 m) every robot of the demo is within 15 m and keeps its label; with 100 robots on the site the far
 * ones are many and small (a 2-degree label at 20 m is a tangle of text over the next room), and fading them clears
 * the view without hiding anything the operator acts on: the selected robot's label and a warning's never fade.
 */

/** A label's height on screen, as an angle (rad): ~2 degrees, 27 px in a 60-degree desktop view 800 px high,
 * ~40 px on a Quest 3. Within LABEL_MIN..LABEL_MAX metres: not a wall of text up close (it was 0.26 m whatever
 * the distance under 5 m, larger than the robot), not a billboard across the site. */
export const LABEL_ANGLE = 0.035;
export const LABEL_MIN = 0.07;
export const LABEL_MAX = 1.5;
/** Labels fade out between these distances (m). */
export const FADE_START = 16;
export const FADE_END = 24;

/** The label's height (m) at a distance (m) from the viewer. @param {number} distance */
export function labelHeight(distance) {
  return Math.min(LABEL_MAX, Math.max(LABEL_MIN, LABEL_ANGLE * distance));
}

/**
 * The label's opacity, 0..1, at a distance (m) from the viewer.
 * @param {number} distance @param {boolean} [keep] the selected robot's or a warning's label: never faded
 */
export function labelOpacity(distance, keep = false) {
  if (keep || distance <= FADE_START) return 1;
  if (distance >= FADE_END) return 0;
  return 1 - (distance - FADE_START) / (FADE_END - FADE_START);
}
