// @ts-check
/**
 * One image of the VR finding card (the capture, or a changed finding's before image): loaded once per address,
 * its size known when it has loaded, and whether it failed. The card draws what is loaded and says what is not.
 */
export class CardImage {
  constructor() {
    /** @type {HTMLImageElement | null} */
    this.image = null;
    /** @type {[number, number] | null} */
    this.size = null;
    this.src = '';
    /** @type {'none' | 'loading' | 'loaded' | 'failed'} */
    this.state = 'none';
  }

  /** Load `src` unless it is the one loaded or loading ('' forgets the image). @param {string} src */
  load(src) {
    if (src === this.src) return;
    this.src = src;
    this.size = null;
    this.state = src ? 'loading' : 'none';
    if (!src) return;
    const img = new Image();
    img.onload = () => {
      if (this.src !== src) return;
      this.image = img;
      this.size = [img.naturalWidth, img.naturalHeight];
      this.state = 'loaded';
    };
    img.onerror = () => {
      if (this.src === src) this.state = 'failed';
    };
    img.src = src;
  }
}
