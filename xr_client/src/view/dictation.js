// @ts-check
/**
 * A note dictated in VR, where there is no keyboard: one phrase through the browser's speech recogniser (the Web
 * Speech API, as voice_control.js's commands), handed to whoever asked for it. Where the browser has none (Firefox,
 * Quest Browser today) the state says so and the card's Dictate button is disabled.
 */

/**
 * @typedef {{start(): void, stop(): void, abort(): void, lang: string, continuous: boolean, interimResults: boolean,
 *   onresult: ((event: any) => void) | null, onerror: ((event: any) => void) | null, onend: (() => void) | null}}
 *   Recognition
 */

/** The browser's recogniser class, or null. @returns {(new () => Recognition) | null} */
export function recognizerClass() {
  const w = /** @type {any} */ (globalThis);
  return w.SpeechRecognition ?? w.webkitSpeechRecognition ?? null;
}

/**
 * A recogniser for one phrase: each final transcript to ``heard``, what went wrong (not silence, not an abort) to
 * ``failed``, its end to ``ended``. Not started. Voice commands (voice_control.js) and dictation make theirs here.
 * @param {new () => Recognition} Recognizer @param {(text: string) => void} heard
 * @param {(error: string) => void} failed @param {() => void} ended
 */
export function onePhrase(Recognizer, heard, failed, ended) {
  const recognition = new Recognizer();
  recognition.lang = 'en-US';
  recognition.continuous = false;
  recognition.interimResults = false;
  recognition.onresult = (event) => {
    for (let i = event.resultIndex ?? 0; i < event.results.length; i++) {
      const result = event.results[i];
      if (result.isFinal !== false) heard(String(result[0]?.transcript ?? ''));
    }
  };
  recognition.onerror = (event) => {
    if (event?.error !== 'no-speech' && event?.error !== 'aborted') failed(event?.error ?? 'recognition failed');
  };
  recognition.onend = ended;
  return recognition;
}

export class Dictation {
  /**
   * @param {(text: string) => void} say what went wrong, for the operator
   * @param {(new () => Recognition) | null} [Recognizer]
   */
  constructor(say, Recognizer = recognizerClass()) {
    this.say = say;
    this.Recognizer = Recognizer;
    /** @type {Recognition | null} */
    this.recognition = null;
  }

  /** 'none': this browser cannot; 'listening': a phrase is being taken; else 'ready'. */
  get state() {
    if (!this.Recognizer) return 'none';
    return this.recognition ? 'listening' : 'ready';
  }

  /**
   * Take one phrase; ``heard`` gets its final transcript (not called when nothing was said). A second start while
   * listening stops the first: the button is a toggle. @param {(text: string) => void} heard
   */
  start(heard) {
    if (this.recognition) {
      this.recognition.stop();
      return;
    }
    if (!this.Recognizer) return;
    const recognition = onePhrase(
      this.Recognizer,
      (text) => {
        if (text.trim()) heard(text.trim());
      },
      (error) => this.say(`dictation: ${error}`),
      () => {
        if (this.recognition === recognition) this.recognition = null;
      },
    );
    this.recognition = recognition;
    try {
      recognition.start();
    } catch (error) {
      this.recognition = null;
      this.say(`dictation: ${/** @type {Error} */ (error).message}`);
    }
  }
}
