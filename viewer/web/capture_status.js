// The words of a capture's status, named once for the viewer and the scout
// app. They are documents/capture_status.h's, where the C++ names them
// (which document carries which word, and who writes it: docs/api.md);
// documents_tests (CaptureStatusWords) fails when the two lists differ.
//
// A capture's document says STORED or NEEDS_GPS as uploaded, then
// REGISTERED or REJECTED from the engine (STORED again while its site waits
// for more captures), or WITHDRAWN. A model's `captures` say REGISTERED,
// PENDING or REJECTED.

export const CaptureStatus = Object.freeze({
  REGISTERED: 'registered',
  PENDING: 'pending',
  REJECTED: 'rejected',
  STORED: 'stored',
  NEEDS_GPS: 'needs-gps',
  WITHDRAWN: 'withdrawn',
});
