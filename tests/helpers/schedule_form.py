"""The desktop page's schedule form (under the schedule list in the findings panel), filled as an inspection lead
would: a name, the targets in order, a robot, a repeat in minutes and a first run some seconds from now."""

from __future__ import annotations

from collections.abc import Sequence

from playwright.async_api import Page

FORM = "#findings .schedule-form"
#: A local time as a datetime-local input takes it, `seconds` from now on the page's clock.
LOCAL_TIME = """(seconds) => {
  const d = new Date(Date.now() + seconds * 1000);
  const two = (n) => String(n).padStart(2, '0');
  return `${d.getFullYear()}-${two(d.getMonth() + 1)}-${two(d.getDate())}T` +
    `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
}"""


async def fill_schedule(
    page: Page, name: str, targets: Sequence[str], robot: str, repeat_minutes: str, start_in: float
) -> None:
    """Open a new schedule's form and fill it (not saved): ``repeat_minutes`` as typed, the first run
    ``start_in`` seconds from now."""
    await page.click("#findings button[data-schedule-new]")
    await page.fill(f"{FORM} input[name='schedule']", name)
    for target in targets:
        await page.check(f"{FORM} input[name='target'][value='{target}']")
    await page.select_option(f"{FORM} select[name='robot']", robot)
    await page.fill(f"{FORM} input[name='repeat']", repeat_minutes)
    await page.fill(f"{FORM} input[name='start']", await page.evaluate(LOCAL_TIME, start_in))
