// Speed of the report's interactive panels in headless Chromium, by performance.now()
// inside the page (benches/browser/run.sh builds the five-model demo report and runs this):
//
//   NODE_PATH=target/browser-test/node_modules node panels_speed.cjs PAGE.html CHROMIUM [REPEATS]
//
// Prints JSON: load (ms from navigation start until every panel has drawn and the page
// answers input), the page's size, and per control the median and largest time of a
// redraw after one input event (the handlers draw synchronously, so the time of the
// dispatch is the redraw's).
'use strict';
const path = require('path');
const fs = require('fs');
const { chromium } = require('playwright-core');
const [page_path, exe, repeats_arg] = process.argv.slice(2);
const repeats = +(repeats_arg || 15);

async function main() {
  const browser = await chromium.launch({ executablePath: exe, headless: true,
    args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader'] });
  const loads = [];
  let result = null;
  for (let run = 0; run < 3; run++) {
    const page = await browser.newPage({ viewport: { width: 1320, height: 1000 } });
    await page.goto('file://' + path.resolve(page_path));
    await page.waitForFunction(() => window.brdfkitView && window.brdfkitView.ready, null, { timeout: 60000 });
    loads.push(await page.evaluate(() => window.brdfkitView.timings.load));
    if (run < 2) { await page.close(); continue; }
    result = await page.evaluate((repeats) => {
      function time(id, values) {
        const el = document.getElementById(id), t = [];
        for (let r = 0; r < repeats; r++) {
          el.value = String(values[r % values.length]);
          const t0 = performance.now();
          el.dispatchEvent(new Event('input', { bubbles: true }));
          t.push(performance.now() - t0);
        }
        t.sort((a, b) => a - b);
        return { median_ms: t[t.length >> 1], max_ms: t[t.length - 1] };
      }
      const out = {};
      out['incidence θi'] = time('inc-theta', [10, 30, 50, 70, 85]);
      out['incidence φ'] = time('inc-phi', [0, 45, 90, 135]);
      out['slice φd'] = time('slice-phi', [0, 30, 60, 90, 120]);
      out['albedo θo'] = time('albedo-theta', [0, 20, 40, 60, 80]);
      document.getElementById('sphere-mode').value = 'single';
      out['sphere 256² (exposure)'] = time('sphere-exposure', [-1, 0, 1, 2]);
      document.getElementById('sphere-mode').value = 'side';
      out['sphere 2 × 256² (side by side)'] = time('sphere-exposure', [-1, 0, 1, 2]);
      out.sources = window.brdfkitView.sources.length;
      return out;
    }, repeats);
  }
  loads.sort((a, b) => a - b);
  result.load_ms = { median: loads[1], all: loads };
  result.page_mb = fs.statSync(page_path).size / 1e6;
  result.chromium = browser.version();
  await browser.close();
  console.log(JSON.stringify(result, null, 2));
}
main().catch((e) => { console.error(e); process.exit(1); });
