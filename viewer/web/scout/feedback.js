// What a photo's state means for the scout, in the words of the field.
//
// The engine's reasons are written for operators ("absolute pose failed
// (12 2D-3D matches, 5 inliers)"); a scout needs to know what to do next.
// Each known reason maps to advice; an unknown one is shown as it is.

import { CaptureStatus } from '../capture_status.js';

const ADVICE = [
  [/no verified matches with any nearby capture/i,
    'too little overlap with earlier photos: step back or turn less between shots'],
  [/matches reach no point of the model/i,
    'not linked to the model yet: take a photo between this one and the last placed one'],
  [/too few matches to the model|absolute pose failed/i,
    'too little overlap with the model: step back or turn less, and keep the building in view'],
  [/well-conditioned initial pair/i,
    'waiting for a second view from a step or two aside (not from the same spot)'],
  [/no GPS fix/i,
    'no position: wait for a GPS fix before shooting'],
  [/decode|image/i,
    'the photo could not be read: take it again'],
];

/** Advice for an engine or server reason. */
export function advice(reason) {
  if (!reason) return '';
  for (const [pattern, words] of ADVICE) if (pattern.test(reason)) return words;
  return reason;
}

/**
 * The one line a photo's row shows: { label, tone } where tone is 'ok',
 * 'busy', 'bad' or 'muted'.
 */
export function describe(photo) {
  switch (photo.state) {
    case 'waiting':
      return { label: photo.error ? `waiting: ${photo.error}` : 'waiting to send', tone: 'busy' };
    case 'sending':
      return { label: 'sending…', tone: 'busy' };
    case 'no-fix':
      return { label: 'waiting for a position: sent with the first GPS fix', tone: 'busy' };
    case 'refused':
      return { label: `refused by the server: ${photo.error}`, tone: 'bad' };
    case 'withdrawn':
      return { label: 'withdrawn', tone: 'muted' };
    default:
      break;
  }
  switch (photo.status) {
    case CaptureStatus.REGISTERED:
      return {
        label: photo.modelVersion ? `registered · model v${photo.modelVersion}` : 'registered',
        tone: 'ok',
      };
    case CaptureStatus.REJECTED:
      return { label: `rejected: ${advice(photo.reason)}`, tone: 'bad' };
    case CaptureStatus.PENDING:
      return { label: `not placed yet: ${advice(photo.reason)}`, tone: 'busy' };
    case CaptureStatus.NEEDS_GPS:
      return { label: 'stored without a position: it joins your next photo with a fix (within 10 minutes)', tone: 'busy' };
    case CaptureStatus.WITHDRAWN:
      return { label: 'withdrawn', tone: 'muted' };
    default:
      return { label: 'stored · waiting for the engine', tone: 'busy' };
  }
}
