// @ts-check
/**
 * The VR menu's robot row in pages: a fleet larger than one row holds (20 robots' buttons were unlabelled slivers)
 * shows a page of robots with their full names, `‹` / `›` to turn the pages (round: from the first page `‹` goes to
 * the last), and which robots the page holds ("robots 7-12 of 20"). No DOM: MenuState keeps one, menu_buttons.js
 * builds the row from `shown()`.
 */

/**
 * Robots on a page of the VR menu: six buttons across the panel's 856-pixel row leave each name ~112 pixels, a
 * `robot100` in letters near the row's 26 px. The desktop menu turns to its robot picker past the same count.
 */
export const ROBOTS_PER_PAGE = 6;

/** @typedef {{first: number, last: number, total: number, paged: boolean}} RobotPage indexes: last excluded */

export class RobotPages {
  /** @param {number} [perPage] */
  constructor(perPage = ROBOTS_PER_PAGE) {
    this.perPage = perPage;
    /** The page turned to (0-based); shown clamped to the fleet's pages, which may have shrunk since. */
    this.page = 0;
  }

  /** @param {number} total robots @returns {number} */
  count(total) {
    return Math.max(1, Math.ceil(total / this.perPage));
  }

  /** The robots (indexes) the row shows now. @param {number} total @returns {RobotPage} */
  shown(total) {
    const page = Math.min(this.page, this.count(total) - 1);
    const first = page * this.perPage;
    return { first, last: Math.min(total, first + this.perPage), total, paged: total > this.perPage };
  }

  /** Turn to the page that holds a robot (its index; -1, none selected: the page stays). @param {number} index */
  show(index) {
    if (index >= 0) this.page = Math.floor(index / this.perPage);
  }

  /**
   * `‹` (prev) or `›` (next), round the ends. @param {string} which `prev` | `next` @param {number} total robots
   */
  turn(which, total) {
    const count = this.count(total);
    const page = Math.min(this.page, count - 1);
    if (which === 'next') this.page = (page + 1) % count;
    else if (which === 'prev') this.page = (page - 1 + count) % count;
  }
}

/** "robots 7-12 of 20": the row's label. @param {RobotPage} page */
export function pageLabel(page) {
  return `robots ${page.first + 1}-${page.last} of ${page.total}`;
}
