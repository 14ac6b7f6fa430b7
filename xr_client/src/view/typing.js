// @ts-check
/**
 * Whether a key went to a field the operator types in (a text input, a note's textarea): the page's letter keys
 * (V to talk, M to mute, H to frame, WASD) are then letters, never commands. Space and Esc stay the E-STOP
 * (desktop_keys.js), except Space in a field whose text may have one (data-space="text").
 */

/** @param {EventTarget | null} target */
export function typingIn(target) {
  return target instanceof HTMLElement && (target.tagName === 'INPUT' || target.tagName === 'TEXTAREA');
}
