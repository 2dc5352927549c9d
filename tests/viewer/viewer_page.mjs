// Shared by the browser tests that drive the web viewer's 3D view
// (lod_browser_test.mjs, wall_height_browser_test.mjs) through what
// viewer/web/app.js exposes as window.arscoutViewer.

/**
 * Renders until the streamed cloud has every node the view wants; returns
 * the drawn figures {total, drawn, budget, loaded}.
 */
export async function settleView(page) {
  await page.waitForFunction(() => {
    const { viewer } = window.arscoutViewer;
    viewer.renderNow();
    return viewer.lod.settled;
  }, null, { timeout: 300000, polling: 250 });
  return page.evaluate(() => {
    const { lod } = window.arscoutViewer.viewer;
    return { total: lod.totalPoints, drawn: lod.drawnPoints, budget: lod.budget, loaded: lod.loadedPoints };
  });
}

/** Moves the camera to `eye`, looking at `target`, and settles. */
export async function lookAt(page, eye, target) {
  await page.evaluate(([e, t]) => {
    const { viewer } = window.arscoutViewer;
    viewer.camera.position.set(...e);
    viewer.controls.target.set(...t);
    viewer.controls.update();
  }, [eye, target]);
  return settleView(page);
}

/** Where the world point [x, y, z] is drawn, in page pixels; null behind the eye. */
export async function screenPosition(page, point) {
  return page.evaluate(([x, y, z]) => {
    const { viewer } = window.arscoutViewer;
    const p = viewer.toScreen({ x, y, z });
    const rect = viewer.canvas.getBoundingClientRect();
    return p && { x: rect.left + p.x, y: rect.top + p.y };
  }, point);
}
