// @ts-check
/**
 * The relay's inspection reports the desktop's findings list links to (docs/inspection.md, Reports): the report and
 * the work orders of the mission a finding came from (all robots of that start: the group id before the first dot),
 * and the page that asks for a range of dates. The operator token rides as `?token=`, as for capture images.
 */

/**
 * @typedef {{ text: string, href: string, title: string }} ReportLink
 */

/**
 * @param {string | null | undefined} mission the mission of the selected (else the newest) finding, if any
 * @param {string | null} token the operator token, or null (viewers allowed)
 * @returns {ReportLink[]}
 */
export function reportLinks(mission, token) {
  const query = token ? `?token=${encodeURIComponent(token)}` : '';
  const links = [];
  const group = mission ? mission.split('.')[0] : '';
  if (group) {
    const base = `/report/${encodeURIComponent(group)}`;
    links.push({ text: 'Report', href: `${base}.html${query}`, title: `the report of mission ${group}` });
    links.push({
      text: 'Work orders',
      href: `${base}.workorders.csv${query}`,
      title: `work orders (CSV) of mission ${group}`,
    });
  }
  links.push({ text: 'Range…', href: `/report/range.html${query}`, title: 'a report of chosen dates' });
  return links;
}
