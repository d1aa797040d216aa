// The system Chromium as every browser check here starts it: headless, software WebGL
// (SwiftShader through ANGLE: this machine and CI have no GPU), and no background
// traffic. Shared by browser/panels.cjs, browser/scattered.cjs and engines/threejs.cjs.
const { chromium } = require('playwright-core');

function launch(exe) {
  return chromium.launch({
    executablePath: exe,
    headless: true,
    args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader',
      '--disable-background-networking', '--disable-component-update'],
  });
}

// A page of that Chromium at `viewport`, whose console errors, uncaught exceptions and
// failed requests are collected into `errors`: what browser/panels.cjs and
// browser/scattered.cjs report.
async function openPage(exe, viewport) {
  const browser = await launch(exe);
  const errors = [];
  const page = await browser.newPage({ viewport });
  page.on('console', (m) => { if (m.type() === 'error') errors.push('console: ' + m.text()); });
  page.on('pageerror', (e) => errors.push('exception: ' + e.message));
  page.on('requestfailed', (r) => errors.push('request failed: ' + r.url()));
  return { browser, page, errors };
}

module.exports = { launch, openPage };
