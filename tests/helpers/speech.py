"""Speech in the browser tests: Chromium headless has no recogniser, so a page gets a stand-in for the Web Speech
API's SpeechRecognition (or none) before its scripts run, and the test makes it hear a phrase."""

from __future__ import annotations

from typing import Any

from playwright.async_api import Browser

from tests.helpers.browser import HEADSET, SOFTWARE_GL, Client

#: A stand-in for the browser's SpeechRecognition: start() records the instance; the test makes it "hear" a phrase
#: with window.__speech.say(text), delivered as the Web Speech API delivers a final result, then ends.
FAKE_SPEECH = """
(() => {
  const speech = { started: 0, stopped: 0, current: null };
  class FakeRecognition {
    constructor() { this.lang = ''; this.continuous = false; this.interimResults = false;
      this.onresult = null; this.onerror = null; this.onend = null; }
    start() { speech.started++; speech.current = this; }
    stop() { speech.stopped++; }
    abort() { speech.stopped++; }
  }
  speech.say = (text) => {
    const r = speech.current;
    if (!r) throw new Error('nobody is listening');
    const result = [{ transcript: text, confidence: 0.9 }];
    result.isFinal = true;
    r.onresult && r.onresult({ resultIndex: 0, results: [result] });
    r.onend && r.onend();
    speech.current = null;
  };
  window.SpeechRecognition = FakeRecognition;
  window.webkitSpeechRecognition = FakeRecognition;
  window.__speech = speech;
})();
"""

NO_SPEECH = "delete window.SpeechRecognition; delete window.webkitSpeechRecognition;"


async def open_page(
    browser: Browser, url: str, name: str, script: str, *, vr: bool = False, size: tuple[int, int] = (1280, 760)
) -> Client:
    page = await browser.new_page(viewport={"width": size[0], "height": size[1]})
    await page.add_init_script(script)
    client = Client(page, name)
    await page.goto(f"{url}/?{HEADSET + '&' if vr else ''}{SOFTWARE_GL}&name=Vera")
    await client.wait("s.connected && Object.keys(s.robots).length > 0 && s.twin.state !== 'loading'", 30)
    return client


async def say(client: Client, text: str) -> dict[str, Any]:
    """Hold V, say ``text``, release V; returns the voice state once the phrase was handled."""
    page = client.page
    await page.keyboard.down("v")
    await client.wait("s.voice.listening", 10)
    await page.evaluate("(text) => window.__speech.say(text)", text)
    await page.keyboard.up("v")
    state: dict[str, Any] = await client.wait("s.voice.heard === arg && !s.voice.listening && s.voice", 10, text)
    return state
