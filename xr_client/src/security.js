// @ts-check
/**
 * Why immersive VR is or is not available on this page, in words the operator can act on. WebXR needs a
 * secure context: https, or http on localhost / 127.0.0.1 (a potentially trustworthy origin).
 */

/**
 * @param {{secure: boolean, hostname: string, port: string, hasXR: boolean, vrSupported: boolean | null}} page
 * @returns {{available: boolean, reason: string, fix: string}}
 */
export function vrAvailability(page) {
  const local =
    page.hostname === 'localhost' ||
    page.hostname === '127.0.0.1' ||
    page.hostname === '[::1]' ||
    page.hostname.endsWith('.localhost');
  if (!page.secure && !local) {
    const port = page.port || '8080';
    return {
      available: false,
      reason:
        `VR needs a secure context, and http://${page.hostname}${page.port ? `:${page.port}` : ''} is not one ` +
        '(only https or localhost are).',
      fix:
        `Either start the relay with \`--host 0.0.0.0 --tls auto\` and open the https://…:8443 address it prints, ` +
        `or connect the headset by USB and run \`adb reverse tcp:${port} tcp:${port}\`, then open ` +
        `http://localhost:${port}/ in the headset's browser.`,
    };
  }
  if (!page.hasXR) {
    return {
      available: false,
      reason: 'This browser has no WebXR (navigator.xr is missing).',
      fix:
        'Open this page in a headset browser (Meta Quest Browser, Safari on Apple Vision Pro) or a WebXR-capable ' +
        'desktop browser; the desktop view below works everywhere.',
    };
  }
  if (page.vrSupported === false) {
    return {
      available: false,
      reason: 'This browser has WebXR but no immersive VR device.',
      fix: 'Connect a headset (or add ?emulate=quest3 to the address to try the VR view with an emulated headset).',
    };
  }
  return {
    available: page.vrSupported === true,
    reason: page.vrSupported === null ? 'checking for a VR device…' : '',
    fix: '',
  };
}

/**
 * This page's VR availability: before the browser answered (`ask: false`), or after asking it whether an
 * immersive session is supported (a secure-context or permissions-policy refusal counts as no).
 * @param {{ask: boolean}} options
 * @returns {Promise<{available: boolean, reason: string, fix: string}>}
 */
export async function pageVrAvailability({ ask }) {
  /** @type {boolean | null} */
  let supported = null;
  if (ask && navigator.xr) {
    try {
      supported = await navigator.xr.isSessionSupported('immersive-vr');
    } catch {
      supported = false;
    }
  }
  return vrAvailability({
    secure: window.isSecureContext,
    hostname: location.hostname,
    port: location.port,
    hasXR: 'xr' in navigator,
    vrSupported: supported,
  });
}
