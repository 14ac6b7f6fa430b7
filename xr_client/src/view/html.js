// @ts-check
/** Text put into the page's markup: every character that could open a tag or close an attribute, escaped. */

/** @param {string} text */
export function esc(text) {
  return text.replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
}
