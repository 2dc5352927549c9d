// The scout app's phone for the browser tests (scout_app_test.mjs,
// coverage_browser_test.mjs): a phone's viewport and touch, a fake rear
// camera and a fake GPS the test drives through window.__fake (setFix,
// denyLocation, showPhoto).

/**
 * In the page before any script: getUserMedia returns a canvas stream at
 * the photo's full size, and geolocation answers with the fix the test
 * sets, altitude included, as a phone's GPS does.
 */
export function installFakes() {
  const fake = { watchers: new Map(), nextWatch: 1, fix: null, denied: false, image: null, frames: 0 };
  window.__fake = fake;
  const canvas = document.createElement('canvas');
  canvas.width = 3072;
  canvas.height = 2048;
  const g = canvas.getContext('2d');
  const paint = () => {
    if (fake.image) g.drawImage(fake.image, 0, 0, canvas.width, canvas.height);
    else g.fillRect(0, 0, canvas.width, canvas.height);
    fake.frames++;
  };
  setInterval(paint, 100);
  fake.showPhoto = async (base64) => {
    const bytes = Uint8Array.from(atob(base64), (c) => c.charCodeAt(0));
    fake.image = await createImageBitmap(new Blob([bytes], { type: 'image/jpeg' }));
    paint();
  };
  navigator.mediaDevices.getUserMedia = async () => {
    paint();
    return canvas.captureStream(10);
  };
  const position = () => ({
    timestamp: Date.now(),
    coords: {
      latitude: fake.fix.lat, longitude: fake.fix.lon, altitude: fake.fix.alt,
      accuracy: fake.fix.hAcc, altitudeAccuracy: fake.fix.vAcc, heading: null, speed: null,
    },
  });
  const denial = { code: 1, message: 'User denied Geolocation', PERMISSION_DENIED: 1 };
  fake.setFix = (fix) => {
    fake.fix = fix;
    fake.denied = false;
    for (const { ok } of fake.watchers.values()) ok(position());
  };
  /** The scout refused the location permission: every watcher hears it. */
  fake.denyLocation = () => {
    fake.fix = null;
    fake.denied = true;
    for (const { err } of fake.watchers.values()) if (err) err(denial);
  };
  const geolocation = {
    watchPosition(ok, err) {
      const id = fake.nextWatch++;
      fake.watchers.set(id, { ok, err });
      if (fake.fix) setTimeout(() => ok(position()), 0);
      else if (fake.denied && err) setTimeout(() => err(denial), 0);
      return id;
    },
    clearWatch(id) {
      fake.watchers.delete(id);
    },
    getCurrentPosition(ok) {
      if (fake.fix) setTimeout(() => ok(position()), 0);
    },
  };
  Object.defineProperty(navigator, 'geolocation', { value: geolocation, configurable: true });
}

/** A phone (viewport, touch) with the fake camera and geolocation. */
export async function phoneContext(browser) {
  const context = await browser.newContext({
    viewport: { width: 390, height: 844 },
    deviceScaleFactor: 2,
    isMobile: true,
    hasTouch: true,
  });
  await context.addInitScript(installFakes);
  return context;
}
