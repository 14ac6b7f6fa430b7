// A finding's note: written on the desktop, read whole on the VR card, dictated there where the browser can.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { wrapLines } from '../src/view/canvas_text.js';
import { Dictation } from '../src/view/dictation.js';
import { InspectionReview, MAX_NOTE, appendNote } from '../src/inspection_review.js';
import { CARD_PX, cardHit, cardLayout } from '../src/finding_card_layout.js';

/** A context whose every character is 10 px wide. */
const tenPx = { measureText: (/** @type {string} */ s) => ({ width: 10 * s.length }) };

test('a note wraps at spaces within the width, cuts a word wider than a line, and ends in an ellipsis when cut short', () => {
  assert.deepEqual(wrapLines(tenPx, 'valve B drips  onto the floor', 100, 5), ['valve B', 'drips onto', 'the floor']);
  assert.deepEqual(wrapLines(tenPx, 'x'.repeat(25), 100, 5), ['x'.repeat(10), 'x'.repeat(10), 'x'.repeat(5)]);
  const words = Array.from({ length: 200 }, (_, i) => `w${i}`).join(' ');
  const lines = wrapLines(tenPx, words, 200, 20);
  assert.equal(lines.length, 20);
  assert.ok(lines.every((l) => l.length * 10 <= 200));
  assert.ok(lines[19].endsWith('…') && !lines[18].endsWith('…'));
  assert.deepEqual(wrapLines(tenPx, '', 100, 3), []);
  // 1000 characters of words fit the card's note box (568 x 552 px at 20 px on 24 px lines, 11 px a character or less).
  const note = Array.from({ length: 200 }, (_, i) => `n${String(i).padStart(3, '0')}`).join(' ');
  assert.equal(note.length, 999);
  const elevenPx = { measureText: (/** @type {string} */ s) => ({ width: 11 * s.length }) };
  const shown = wrapLines(elevenPx, note, 600 - 32, Math.floor((552 - 24) / 24));
  assert.equal(shown.join(' '), note);
});

test('a note is set trimmed within the limit, cleared with nothing, and a dictated phrase is added after it', () => {
  const review = new InspectionReview();
  assert.deepEqual(review.setNote('x'), [], 'no finding open: nothing sent');
  review.select('f-1');
  assert.deepEqual(review.setNote('  leak at the flange '), [
    { type: 'finding_update', finding: 'f-1', fields: { note: 'leak at the flange' } },
  ]);
  assert.deepEqual(review.setNote(''), [{ type: 'finding_update', finding: 'f-1', fields: { note: '' } }]);
  assert.equal(/** @type {any} */ (review.setNote('y'.repeat(1500))[0]).fields.note.length, MAX_NOTE);
  assert.deepEqual(review.setNote('later', 'f-0'), [
    { type: 'finding_update', finding: 'f-0', fields: { note: 'later' } },
  ]);
  assert.equal(appendNote('leak at the flange', ' call the fitter '), 'leak at the flange call the fitter');
  assert.equal(appendNote('', 'call the fitter'), 'call the fitter');
  assert.equal(appendNote('z'.repeat(999), 'more').length, MAX_NOTE);
});

test("the card's Note shows the note in the image's place, with Dictate (where the browser can) and Clear", () => {
  const base = {
    status: 'ok',
    proposal: false,
    imageAction: /** @type {const} */ ('region'),
    imageSize: /** @type {[number, number]} */ ([480, 480]),
  };
  const image = cardLayout({ ...base, operator: true });
  assert.ok(image.image && image.note === null);
  assert.deepEqual(
    image.buttons.filter((b) => b.id.startsWith('card:')).map((b) => [b.id, b.active]),
    [
      ['card:image', true],
      ['card:note', false],
      ['card:close', false],
    ],
  );
  const reading = cardLayout({ ...base, operator: true, note: true, dictation: 'ready' });
  assert.equal(reading.image, null, 'no pixel of the capture is hit while the note shows');
  assert.ok(reading.note && reading.note.x + reading.note.w < CARD_PX[0] / 2 + 200);
  const ids = reading.buttons.map((b) => b.id);
  assert.ok(ids.includes('note:dictate') && ids.includes('note:clear') && !ids.includes('image:region'));
  const at = (/** @type {ReturnType<typeof cardLayout>} */ l, /** @type {string} */ id) => {
    const b = /** @type {import('../src/finding_card_layout.js').CardButton} */ (l.buttons.find((x) => x.id === id));
    return cardHit(l, [480, 480], b.x + b.w / 2, b.y + b.h / 2);
  };
  assert.deepEqual(at(reading, 'note:dictate'), { button: 'note:dictate' });
  assert.deepEqual(at(reading, 'card:note'), { button: 'card:note' });
  assert.equal(
    at(cardLayout({ ...base, operator: true, note: true, dictation: 'none' }), 'note:dictate'),
    null,
    'no recogniser',
  );
  const viewer = cardLayout({ ...base, operator: false, note: true, dictation: 'ready' });
  assert.equal(at(viewer, 'note:dictate'), null, 'a viewer reads the note and writes none');
  assert.equal(at(viewer, 'note:clear'), null);
  assert.deepEqual(at(viewer, 'card:image'), { button: 'card:image' });
  const listening = cardLayout({ ...base, operator: true, note: true, dictation: 'listening' });
  const dictate = listening.buttons.find((b) => b.id === 'note:dictate');
  assert.equal(dictate?.label, 'Listening…');
  assert.ok(dictate?.active);
  const changed = cardLayout({ ...base, operator: true, before: 'before', note: true });
  assert.deepEqual(
    changed.buttons.filter((b) => b.id.startsWith('card:')).map((b) => [b.id, b.active]),
    [
      ['card:after', false],
      ['card:before', false],
      ['card:note', true],
      ['card:close', false],
    ],
  );
});

test('a dictation takes one phrase, toggles off when pressed again, and says what went wrong', () => {
  /** @type {any[]} */
  const made = [];
  class FakeRecognition {
    constructor() {
      made.push(this);
      this.started = 0;
      this.stopped = 0;
      /** @type {any} */ this.onresult = null;
      /** @type {any} */ this.onerror = null;
      /** @type {any} */ this.onend = null;
    }
    start() {
      this.started++;
    }
    stop() {
      this.stopped++;
    }
    abort() {}
  }
  /** @type {string[]} */
  const said = [];
  /** @type {string[]} */
  const heard = [];
  const dictation = new Dictation((t) => said.push(t), /** @type {any} */ (FakeRecognition));
  assert.equal(dictation.state, 'ready');
  dictation.start((t) => heard.push(t));
  assert.equal(dictation.state, 'listening');
  const r = made[0];
  r.onresult({ resultIndex: 0, results: [Object.assign([{ transcript: ' gauge reads high ' }], { isFinal: true })] });
  r.onend();
  assert.deepEqual(heard, ['gauge reads high']);
  assert.equal(dictation.state, 'ready');
  dictation.start((t) => heard.push(t));
  dictation.start((t) => heard.push(t)); // pressed again: stops the phrase being taken
  assert.equal(made.length, 2);
  assert.equal(made[1].stopped, 1);
  made[1].onerror({ error: 'not-allowed' });
  made[1].onerror({ error: 'no-speech' });
  made[1].onend();
  assert.deepEqual(said, ['dictation: not-allowed']);
  assert.equal(new Dictation(() => {}, null).state, 'none');
});
