// The sign-in check (docs/scout-app.md): a token is asked about at the
// server (GET /v1/me, docs/api.md) before the app keeps it, so that a
// mistyped, revoked or expired token, or one for a planner, is told apart
// from a server out of reach before the first photo is taken.

/** What a scout reads for each reason the server gives with its 401. */
const REFUSED = {
  unknown: 'unknown token: this server does not know it. Check it, or ask your team lead for a new one',
  revoked: 'this token was revoked: ask your team lead for a new one',
  expired: 'this token has expired: ask your team lead for a new one',
  malformed: 'this is not a token: it starts "ars_" and has 64 letters and digits after it',
  missing: 'type or scan a token first',
};

export const UNREACHABLE =
  'the server cannot be reached, so the token is not checked yet: photos wait on this phone and are sent when it answers';

/**
 * Asks the server who `token` is. Resolves to
 *   { me }                      the token works for a scout (or an admin);
 *   { problem, keep: false }    the server refused it: do not keep it;
 *   { problem, keep: true }     no answer (offline, or the server down):
 *                               keep it, it is checked again later.
 */
export async function checkToken(token) {
  let response;
  try {
    response = await fetch('/v1/me', {
      headers: { Authorization: `Bearer ${token}` },
      cache: 'no-store',
    });
  } catch {
    return { problem: UNREACHABLE, keep: true };
  }
  if (response.ok) {
    const me = await response.json();
    if (me.role === 'planner') {
      return {
        problem: `wrong role: this is ${me.name}'s planner token, which may look but not upload; a scout needs a scout token`,
        keep: false,
      };
    }
    return { me };
  }
  if (response.status === 401) {
    const body = await response.json().catch(() => ({}));
    return { problem: REFUSED[body.reason] || REFUSED.unknown, keep: false };
  }
  if (response.status === 429) {
    return { problem: 'too many wrong tokens from this network: wait a few minutes, then try again', keep: false };
  }
  // 5xx (the store restarting) and the service worker's offline answer.
  return { problem: UNREACHABLE, keep: true };
}
