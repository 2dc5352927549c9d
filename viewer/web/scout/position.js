// The phone's position (Geolocation API) and heading (compass where the
// platform gives one, else the direction of travel from the GPS).
//
// Browsers report no satellite count, so none is shown or sent: the
// accuracy the platform reports is the measure of the fix.

/** A fix older than this is not attached to a photo. */
export const MAX_FIX_AGE_S = 30;

function explain(err) {
  if (!err) return 'no fix';
  if (err.code === 1) return 'location denied: allow it for this site in the browser; photos wait for a fix';
  if (err.code === 2) return 'no fix: position unavailable';
  if (err.code === 3) return 'no fix yet';
  return `no fix: ${err.message}`;
}

export class Position {
  /** @param {() => void} onUpdate called on every fix, error and heading */
  constructor(onUpdate) {
    this.onUpdate = onUpdate;
    this.fix = null; // { lat, lon, alt, hAcc, vAcc, time (ms) }
    this.heading = null; // degrees clockwise from north
    this.problem = '';
    this.watch = null;
  }

  start() {
    if (!('geolocation' in navigator)) {
      this.problem = 'this browser gives no position';
      this.onUpdate();
      return;
    }
    this.watch = navigator.geolocation.watchPosition(
      (p) => this.received(p),
      (err) => {
        this.problem = explain(err);
        this.onUpdate();
      },
      { enableHighAccuracy: true, maximumAge: 0, timeout: 60000 },
    );
    const compass = (e) => this.compass(e);
    if ('ondeviceorientationabsolute' in window) {
      window.addEventListener('deviceorientationabsolute', compass);
    } else {
      window.addEventListener('deviceorientation', compass);
    }
  }

  received(p) {
    const c = p.coords;
    this.fix = {
      lat: c.latitude,
      lon: c.longitude,
      alt: c.altitude,
      hAcc: c.accuracy,
      vAcc: c.altitudeAccuracy,
      time: p.timestamp || Date.now(),
    };
    if (c.heading !== null && Number.isFinite(c.heading) && c.speed > 0.5 && !this.fromCompass) {
      this.heading = c.heading;
    }
    this.problem = '';
    this.onUpdate();
  }

  compass(e) {
    // iOS gives the compass heading directly; others an absolute alpha
    // (counter-clockwise from north).
    let heading = null;
    if (typeof e.webkitCompassHeading === 'number') heading = e.webkitCompassHeading;
    else if (e.absolute && typeof e.alpha === 'number') heading = (360 - e.alpha) % 360;
    if (heading === null) return;
    this.fromCompass = true;
    this.heading = heading;
    this.onUpdate();
  }

  /** Seconds since the last fix, or null without one. */
  age(now = Date.now()) {
    return this.fix ? Math.max(0, (now - this.fix.time) / 1000) : null;
  }

  /**
   * The fix as the API's `gps` metadata, or null when there is none within
   * MAX_FIX_AGE_S of `now` (a photo's time).
   */
  metadata(now = Date.now()) {
    if (!this.fix || this.age(now) > MAX_FIX_AGE_S) return null;
    const gps = {
      lat: this.fix.lat,
      lon: this.fix.lon,
      h_acc: this.fix.hAcc,
      time: new Date(this.fix.time).toISOString(),
    };
    if (Number.isFinite(this.fix.alt)) {
      gps.alt = this.fix.alt;
      if (Number.isFinite(this.fix.vAcc)) gps.v_acc = this.fix.vAcc;
    }
    return gps;
  }
}
