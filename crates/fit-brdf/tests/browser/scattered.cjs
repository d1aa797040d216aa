// Opens the report on scattered data (`fit-brdf report --samples S` or on a `.bsdf`'s
// points: crates/brdfkit-validate/src/html/scattered_page.rs) in headless Chromium
// (npm playwright-core, the system's Chromium) and writes what a reader would see as
// JSON, for report_browser.rs to check:
//
//   node scattered.cjs PAGE.html OUT.json CHROMIUM SHOT.png
//
// every console error, uncaught exception and failed request; the ids on the page;
// every <img> (loaded, natural and displayed size); the SVG charts of each section
// (size on screen and what they draw); the summary table's rows and the hover text of
// its loss cells (the page's only interactive part: "hover a value for R · G · B"),
// read after a real hover; the checks table; and a full-page screenshot.
'use strict';
const path = require('path');
const fs = require('fs');
const { openPage } = require('./launch.cjs');

const [page_path, out_path, exe, shot_path] = process.argv.slice(2);

async function main() {
  const { browser, page, errors } = await openPage(exe, { width: 1280, height: 1000 });
  await page.goto('file://' + path.resolve(page_path), { waitUntil: 'load' });
  // Every image decoded (data: URIs decode asynchronously after `load` in Chromium).
  await page.evaluate(() => Promise.all([...document.images].map((i) => i.decode().catch(() => null))));

  const out = await page.evaluate(() => {
    const size = (el) => { const r = el.getBoundingClientRect(); return [r.width, r.height]; };
    // The elements between h2#id and the next h2: what the section shows.
    const section = (id) => {
      const h = document.getElementById(id);
      const els = [];
      if (!h) return els;
      for (let e = h.nextElementSibling; e && e.tagName !== 'H2'; e = e.nextElementSibling) els.push(e);
      return els;
    };
    const inside = (b, x, y) => x >= b.left && x <= b.right && y >= b.top && y <= b.bottom;
    const centre = (e) => { const r = e.getBoundingClientRect(); return [(r.left + r.right) / 2, (r.top + r.bottom) / 2]; };
    // What a chart draws, and what would spoil it: text cut off at the chart's edge,
    // and data points under a text or a box drawn over the plot (a legend).
    const chart = (s) => {
      const sb = s.getBoundingClientRect();
      const texts = [...s.querySelectorAll('text')];
      const area = sb.width * sb.height;
      const covers = texts.map((t) => t.getBoundingClientRect()).concat([...s.querySelectorAll('rect')]
        .map((r) => r.getBoundingClientRect()).filter((b) => b.width * b.height < 0.3 * area));
      const out = (b) => b.left < sb.left - 0.5 || b.right > sb.right + 0.5 || b.top < sb.top - 0.5 || b.bottom > sb.bottom + 0.5;
      return {
        size: size(s),
        circles: s.querySelectorAll('circle').length,
        lines: s.querySelectorAll('polyline, path, line').length,
        texts: texts.map((t) => t.textContent.trim()),
        clipped: texts.filter((t) => out(t.getBoundingClientRect())).map((t) => t.textContent.trim()),
        hidden: [...s.querySelectorAll('circle')].filter((c) => { const [x, y] = centre(c); return covers.some((b) => inside(b, x, y)); }).length,
      };
    };
    const svgs = (id) => section(id).flatMap((e) => [...e.querySelectorAll('svg')]).map(chart);
    const note = section('scatter').map((e) => e.textContent).join(' ');
    const drawn = note.match(/(\d+) of (\d+) samples drawn/);
    const table = (el) => el ? [...el.querySelectorAll('tbody tr')].map((tr) =>
      [...tr.querySelectorAll('td')].map((td) => ({ text: td.textContent.trim(), title: td.getAttribute('title') }))) : null;
    return {
      ids: [...document.querySelectorAll('[id]')].map((e) => e.id),
      kind: (document.getElementById('input') || {}).dataset?.kind ?? null,
      images: [...document.images].map((i) => ({
        alt: i.alt, complete: i.complete, natural: [i.naturalWidth, i.naturalHeight], shown: size(i),
      })),
      scatter: svgs('scatter'),
      profiles: svgs('profiles'),
      drawn: drawn ? [Number(drawn[1]), Number(drawn[2])] : null,
      summary: table(document.getElementById('summary-table')),
      checks: table(section('checks').find((e) => e.tagName === 'TABLE')),
      page: [document.documentElement.scrollWidth, document.documentElement.scrollHeight],
    };
  });
  // The hover a reader does: over the first loss cell, which must then be the element
  // under the pointer (nothing drawn over it) and carry its R · G · B.
  const cell = page.locator('#summary-table tbody tr td[title]').first();
  out.hover = null;
  if (await cell.count() > 0) {
    await cell.hover();
    out.hover = await page.evaluate(() => {
      const h = [...document.querySelectorAll(':hover')].pop();
      return h ? { tag: h.tagName, title: h.getAttribute('title') } : null;
    });
  }
  fs.writeFileSync(shot_path, await page.screenshot({ fullPage: true }));
  out.errors = errors;
  await browser.close();
  fs.writeFileSync(out_path, JSON.stringify(out));
}

main().catch((e) => { console.error(e); process.exit(1); });
