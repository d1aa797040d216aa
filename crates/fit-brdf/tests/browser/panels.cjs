// Drives the report's interactive panels in headless Chromium (npm playwright-core, the
// system's Chromium: it never downloads a browser) and writes what it saw as JSON.
//
//   node panels.cjs PAGE.html OUT.json CHROMIUM [SHOTS_DIR]
//
// For each panel: moves every control, takes a screenshot of the panel before and after
// and records whether it changed; reads back the plotted values through the page's test
// hook (window.brdfkitView, documented in the page and in docs/report.md); records every
// console error and uncaught exception. The Rust test (report_browser.rs) compares the
// values with `fit-brdf eval` and fails on any error. With SHOTS_DIR, the screenshots of
// each panel after its controls moved are kept there (docs/report.md's figures).
'use strict';
const path = require('path');
const fs = require('fs');
const { openPage } = require('./launch.cjs');

const [page_path, out_path, exe, shots] = process.argv.slice(2);

async function main() {
  const { browser, page, errors } = await openPage(exe, { width: 1320, height: 1000 });
  await page.goto('file://' + path.resolve(page_path));
  await page.waitForFunction(() => window.brdfkitView && window.brdfkitView.ready, null, { timeout: 30000 });
  const out = { errors, changed: {}, timings: {}, sources: await page.evaluate(() => window.brdfkitView.sources) };
  out.timings.load = await page.evaluate(() => window.brdfkitView.timings.load);

  const shot = (id) => page.locator('#' + id).screenshot();
  // Sets a control's value and fires its input event, as a user's drag does.
  const set = (id, v) => page.evaluate(([id, v]) => {
    const el = document.getElementById(id);
    el.value = String(v);
    el.dispatchEvent(new Event('input', { bubbles: true }));
  }, [id, v]);
  const hook = (expr) => page.evaluate(expr);
  // Moves a control and records whether the panel's picture changed.
  async function move(panel, name, act) {
    const before = await shot(panel);
    await act();
    const after = await shot(panel);
    out.changed[name] = !before.equals(after);
  }
  async function keep(panel) {
    if (shots) fs.writeFileSync(path.join(shots, panel + '.png'), await shot(panel));
  }

  // Incidence plane.
  await move('panel-incidence', 'incidence θi', () => set('inc-theta', 70));
  out.incidence_mirror = await hook(() => window.brdfkitView.plotted.incidence);
  await move('panel-incidence', 'incidence φ', () => set('inc-phi', 30));
  await move('panel-incidence', 'incidence scale', () => set('inc-scale', 'linear'));
  await move('panel-incidence', 'incidence channel', () => set('inc-channel', 0));
  // Hiding the table's curve (a click on its legend entry) and showing it again.
  await move('panel-incidence', 'incidence legend', () => page.locator('#inc-legend span').first().click());
  await page.locator('#inc-legend span').first().click();
  out.incidence = await hook(() => window.brdfkitView.plotted.incidence);
  out.timings.incidence = await hook(() => window.brdfkitView.timings.incidence);
  await set('inc-scale', 'log'); await set('inc-phi', 0);
  await keep('panel-incidence');

  // θh–θd slice.
  const n = out.sources.length;
  await move('panel-slice', 'slice φd', () => set('slice-phi', 45));
  await move('panel-slice', 'slice source', () => set('slice-source', n - 1));
  await move('panel-slice', 'slice mode', () => set('slice-mode', 'ratio'));
  await move('panel-slice', 'slice channel', () => set('slice-channel', 2));
  out.timings.slice = await hook(() => window.brdfkitView.timings.slice);
  // Mouse events go to viewport coordinates: the canvas must be in view.
  await page.locator('#slice-canvas').scrollIntoViewIfNeeded();
  const box = await page.locator('#slice-canvas').boundingBox();
  out.cursors = [];
  for (const [fx, fy] of [[0.12, 0.05], [0.25, 0.3], [0.5, 0.5], [0.4, 0.7], [0.75, 0.2], [0.15, 0.85]]) {
    await page.mouse.move(box.x + fx * box.width, box.y + fy * box.height);
    out.cursors.push(await hook(() => Object.assign({ readout: document.getElementById('slice-readout').textContent },
      window.brdfkitView.plotted.slice.cursor)));
  }
  await keep('panel-slice');

  // Lit sphere.
  await page.locator('#sphere-a').scrollIntoViewIfNeeded();
  const sb = await page.locator('#sphere-a').boundingBox();
  await move('panel-sphere', 'sphere light', async () => {
    await page.mouse.move(sb.x + 0.5 * sb.width, sb.y + 0.5 * sb.height);
    await page.mouse.down();
    await page.mouse.move(sb.x + 0.15 * sb.width, sb.y + 0.4 * sb.height, { steps: 4 });
    await page.mouse.up();
  });
  await move('panel-sphere', 'sphere exposure', () => set('sphere-exposure', 1));
  out.timings.sphere_single = await hook(() => window.brdfkitView.timings.sphere);
  out.probes = [];
  for (let k = 0; k < n; k++) {
    await set('sphere-source', k);
    out.probes.push(await hook(() => window.brdfkitView.plotted.sphere));
  }
  await move('panel-sphere', 'sphere side by side', () => set('sphere-mode', 'side'));
  out.timings.sphere_side = await hook(() => window.brdfkitView.timings.sphere);
  await keep('panel-sphere');
  await move('panel-sphere', 'sphere difference', () => set('sphere-mode', 'diff'));

  // Directional albedo (its curve is computed just after the first draw).
  await page.waitForFunction(() => window.brdfkitView.albedoCurveReady, null, { timeout: 30000 });
  await move('panel-albedo', 'albedo θo', () => set('albedo-theta', 60));
  await move('panel-albedo', 'albedo channel', () => set('albedo-channel', 0));
  out.albedo = await hook(() => window.brdfkitView.plotted.albedo);
  out.timings.albedo = await hook(() => window.brdfkitView.timings.albedo);
  await keep('panel-albedo');

  await browser.close();
  fs.writeFileSync(out_path, JSON.stringify(out));
}

main().catch((e) => { console.error(e); process.exit(1); });
