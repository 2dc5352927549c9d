// The phone's rear camera: a live view and full-resolution JPEG shots.
//
// A shot comes from ImageCapture.takePhoto() where the browser has it (the
// sensor's full resolution, not the preview's), else from the largest
// video frame the camera delivers. Either way it is a JPEG of known size.

const JPEG_QUALITY = 0.92;

export class CameraError extends Error {
  constructor(message) {
    super(message);
    this.name = 'CameraError';
  }
}

/** Words a scout understands for getUserMedia's failures. */
function explain(err) {
  switch (err && err.name) {
    case 'NotAllowedError':
      return 'camera permission denied: allow the camera for this site in the browser settings';
    case 'NotFoundError':
    case 'OverconstrainedError':
      return 'no camera found on this device';
    case 'NotReadableError':
      return 'the camera is in use by another app';
    case 'SecurityError':
      return 'the camera needs a secure connection (https)';
    default:
      return `camera unavailable: ${err && err.message ? err.message : err}`;
  }
}

async function jpegOf(source, width, height) {
  const canvas = document.createElement('canvas');
  canvas.width = width;
  canvas.height = height;
  canvas.getContext('2d').drawImage(source, 0, 0, width, height);
  const blob = await new Promise((resolve) => canvas.toBlob(resolve, 'image/jpeg', JPEG_QUALITY));
  if (!blob) throw new CameraError('the photo could not be encoded');
  return blob;
}

export class Camera {
  /** @param {HTMLVideoElement} video the live view */
  constructor(video) {
    this.video = video;
    this.stream = null;
    this.imageCapture = null;
  }

  get running() {
    return !!this.stream;
  }

  async start() {
    if (!navigator.mediaDevices || !navigator.mediaDevices.getUserMedia) {
      throw new CameraError('this browser gives no camera access here (it needs https)');
    }
    try {
      this.stream = await navigator.mediaDevices.getUserMedia({
        audio: false,
        video: {
          facingMode: { ideal: 'environment' },
          width: { ideal: 4096 },
          height: { ideal: 3072 },
        },
      });
    } catch (err) {
      throw new CameraError(explain(err));
    }
    const track = this.stream.getVideoTracks()[0];
    this.imageCapture = 'ImageCapture' in window && track ? new window.ImageCapture(track) : null;
    this.video.srcObject = this.stream;
    this.video.muted = true;
    this.video.playsInline = true;
    await this.video.play().catch(() => {});
  }

  stop() {
    if (this.stream) this.stream.getTracks().forEach((t) => t.stop());
    this.stream = null;
    this.imageCapture = null;
    this.video.srcObject = null;
  }

  /** A shot: { blob (image/jpeg), width, height }. */
  async takePhoto() {
    if (!this.stream) throw new CameraError('the camera is not running');
    if (this.imageCapture) {
      try {
        const shot = await this.imageCapture.takePhoto();
        const bitmap = await createImageBitmap(shot);
        const { width, height } = bitmap;
        const blob = shot.type === 'image/jpeg' ? shot : await jpegOf(bitmap, width, height);
        bitmap.close();
        return { blob, width, height };
      } catch {
        // Not every track can take photos (a canvas stream, some webcams):
        // the video frame below is the next best.
      }
    }
    const width = this.video.videoWidth;
    const height = this.video.videoHeight;
    if (!width || !height) throw new CameraError('the camera has not delivered a picture yet');
    return { blob: await jpegOf(this.video, width, height), width, height };
  }
}
