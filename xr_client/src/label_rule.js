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

/** The smallest text a label may show (its font, px on the screen): issue #31's 12 px, name and status alike. */
export const LEGIBLE_PX = 12;
/** drawLabel's layout (view/label_sprite.js): the share of a label's height its lines share between them, and each
 * line's font as a share of the line (the name's, then the status lines'). */
export const TEXT_SHARE = 1 - 16 / 150;
export const NAME_FONT = 0.62;
export const LINE_FONT = 0.56;
/** A Quest 3's pixels per radian at the middle of the view (2064 px an eye over about 100 degrees): VR labels are
 * sized for the headset, not for an emulator's window. */
export const HEADSET_PX_PER_RAD = 1100;

/**
 * The angle (rad) of a label of `lines` lines whose every line is at least LEGIBLE_PX on a screen of `pxPerRad`
 * pixels per radian; never under LABEL_ANGLE. A 1280 x 800 desktop view (60 degrees high, 693 px/rad): 0.069 rad
 * for two lines, 48 px; a Quest 3: 0.044 rad.
 * @param {number} lines @param {number} pxPerRad
 */
export function labelAngle(lines, pxPerRad) {
  return Math.max(LABEL_ANGLE, (LEGIBLE_PX * lines) / (TEXT_SHARE * LINE_FONT) / pxPerRad);
}

/** The smallest font (px) of a label `heightPx` tall with `lines` lines (its status lines'). */
export function smallestFont(/** @type {number} */ heightPx, /** @type {number} */ lines) {
  return ((heightPx * TEXT_SHARE) / lines) * LINE_FONT;
}

/** The label's height (m) at a distance (m) from the viewer. @param {number} distance @param {number} [angle] */
export function labelHeight(distance, angle = LABEL_ANGLE) {
  return Math.min(LABEL_MAX, Math.max(LABEL_MIN, angle * distance));
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
