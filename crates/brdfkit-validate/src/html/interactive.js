// The report's interactive panels (brdfkit-validate/src/html/interactive.rs embeds the
// data this reads). No model formula here: every value is a lookup of the embedded grids,
// interpolated as brdfkit's MerlTable::interpolated does. Plain script (no modules): the
// page runs from file://.
(function () {
  'use strict';
  var PI = Math.PI, HALF_PI = PI / 2;
  var tStart = performance.now();
  var D = JSON.parse(document.getElementById('view-data').textContent);
  var NH = D.dims[0], ND = D.dims[1], NP = D.dims[2];
  var SRC = D.sources;
  var hook = { ready: false, sources: SRC.map(function (s) { return s.label; }), plotted: {}, timings: {} };
  window.brdfkitView = hook;
  function $(id) { return document.getElementById(id); }

  // Decoding (interactive.rs, `pack`): base64, zlib (the browser's DecompressionStream),
  // low bytes then high bytes of each plane's differences from the previous cell; a code
  // q is 0 missing (NaN), 1 below the floor (0), else exp(lo + (q − 2)/65533 · (hi − lo)).
  function inflate(b64) {
    var bin = atob(b64), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
    return new Response(stream).arrayBuffer().then(function (b) { return new Uint8Array(b); });
  }
  function decode(s, bytes) {
    var n3 = bytes.length >> 1, n = n3 / 3, out = new Float32Array(n3);
    for (var c = 0; c < 3; c++) {
      // exp(lo + k · step) by repeated multiplication (65,533 roundings of 1.1e-16: far
      // below the Float32 the values are kept in), a tenth of the cost of Math.exp.
      var lut = new Float32Array(65536), step = Math.exp((s.hi[c] - s.lo[c]) / 65533);
      var x = Math.exp(s.lo[c]);
      lut[0] = NaN; lut[1] = 0;
      for (var q = 2; q < 65536; q++) { lut[q] = x; x *= step; }
      var prev = 0;
      for (var i = 0; i < n; i++) {
        var j = c * n + i;
        prev = (prev + (bytes[j] | (bytes[n3 + j] << 8))) & 0xffff;
        out[3 * i + c] = lut[prev];
      }
    }
    return out;
  }
  var GRIDS = null;

  // Rusinkiewicz angles (θh, θd, φd) of (wi, wo), as brdfkit_core::rusinkiewicz::to_half_diff:
  // wi rotated by −φh about the normal, then by −θh about the binormal (y), gives the
  // difference vector. The rotations' cosines and sines are h's own components (cos φh =
  // hx / r, sin φh = hy / r, cos θh = hz, sin θh = r with r = |(hx, hy)|), so the only
  // trigonometry is the three angles themselves; the result differs from brdfkit's by
  // rounding alone.
  function halfDiff(wi, wo, out) {
    if (wi[0] === wo[0] && wi[1] === wo[1] && wi[2] === wo[2]) {
      out[0] = Math.acos(Math.max(-1, Math.min(1, wi[2]))); out[1] = 0; out[2] = 0; return out;
    }
    var hx = wi[0] + wo[0], hy = wi[1] + wo[1], hz = wi[2] + wo[2];
    var norm = Math.sqrt(hx * hx + hy * hy + hz * hz);
    if (norm === 0) { hx = 0; hy = 0; hz = 1; } else { hx /= norm; hy /= norm; hz /= norm; }
    var r = Math.sqrt(hx * hx + hy * hy), c = 1, s = 0;
    if (r > 0) { c = hx / r; s = -hy / r; }
    var x1 = wi[0] * c - wi[1] * s, y1 = wi[1] * c + wi[0] * s, z1 = wi[2];
    var x2 = x1 * hz - z1 * r, z2 = z1 * hz + x1 * r;
    out[0] = Math.acos(Math.max(-1, Math.min(1, hz)));
    out[1] = Math.acos(Math.max(-1, Math.min(1, z2)));
    out[2] = (x2 === 0 && y1 === 0) ? 0 : Math.atan2(y1, x2);
    return out;
  }

  // Multilinear interpolation at index coordinates (u, v, w): θh and θd hold their last
  // node, φd wraps, missing corners are left out and the weights renormalised.
  function clampedAxis(x, n, a) {
    if (!(x > 0)) { a[0] = 0; a[1] = 0; a[2] = 0; return; }
    if (x >= n - 1) { a[0] = n - 1; a[1] = n - 1; a[2] = 0; return; }
    var lo = Math.floor(x); a[0] = lo; a[1] = lo + 1; a[2] = x - lo;
  }
  var AU = [0, 0, 0], AV = [0, 0, 0], AW = [0, 0, 0];
  function interpolate(g, u, v, w, out) {
    clampedAxis(u, NH, AU); clampedAxis(v, ND, AV);
    if (!(w >= 0 && w <= NP)) w = ((w % NP) + NP) % NP;
    var lo = Math.floor(w), k0 = lo % NP; AW[0] = k0; AW[1] = (k0 + 1) % NP; AW[2] = w - lo;
    var r = 0, gg = 0, b = 0, ws = 0;
    for (var a = 0; a < 2; a++) {
      var wu = a ? AU[2] : 1 - AU[2]; if (wu === 0) continue;
      var i = a ? AU[1] : AU[0];
      for (var bb = 0; bb < 2; bb++) {
        var wv = bb ? AV[2] : 1 - AV[2]; if (wv === 0) continue;
        var row = (i * ND + (bb ? AV[1] : AV[0])) * NP;
        for (var cc = 0; cc < 2; cc++) {
          var wt = wu * wv * (cc ? AW[2] : 1 - AW[2]);
          var idx = 3 * (row + (cc ? AW[1] : AW[0]));
          var x = g[idx];
          if (wt === 0 || x !== x) continue;
          r += wt * x; gg += wt * g[idx + 1]; b += wt * g[idx + 2]; ws += wt;
        }
      }
    }
    if (!(ws > 0)) return false;
    out[0] = r / ws; out[1] = gg / ws; out[2] = b / ws; return true;
  }
  var HD = [0, 0, 0];
  function coordsOf(hd, out) {
    out[0] = hd[0] <= 0 ? 0 : Math.sqrt((hd[0] / HALF_PI) * NH * NH);
    out[1] = hd[1] / (PI * 0.5) * ND;
    var p = hd[2] < 0 ? hd[2] + PI : hd[2];
    out[2] = p / PI * NP;
    return out;
  }
  var UVW = [0, 0, 0];
  // f_r of source k at (wi, wo) into out; false where there is no value (below the horizon).
  function lookup(k, wi, wo, out) {
    if (!(wi[2] > 0 && wo[2] > 0)) return false;
    coordsOf(halfDiff(wi, wo, HD), UVW);
    return interpolate(GRIDS[k], UVW[0], UVW[1], UVW[2], out);
  }
  hook.eval = function (k, wi, wo) { var o = [0, 0, 0]; return lookup(k, wi, wo, o) ? o : null; };
  function sph(theta, phi) {
    var s = Math.sin(theta);
    return [s * Math.cos(phi), s * Math.sin(phi), Math.cos(theta)];
  }
  function rad(d) { return d * PI / 180; }
  function timed(name, f) {
    return function () {
      var t = performance.now(); f(); hook.timings[name] = performance.now() - t;
    };
  }

  // --- drawing helpers ---
  var VIRIDIS = [[68, 1, 84], [72, 40, 120], [62, 74, 137], [49, 104, 142], [38, 130, 142],
    [31, 158, 137], [53, 183, 121], [109, 205, 89], [180, 222, 44], [253, 231, 37]];
  function ramp(stops, t, px, o) {
    t = Math.max(0, Math.min(1, t)) * (stops.length - 1);
    var i = Math.min(stops.length - 2, Math.floor(t)), f = t - i;
    for (var c = 0; c < 3; c++) px[o + c] = stops[i][c] + f * (stops[i + 1][c] - stops[i][c]);
  }
  var DIVERGING = [[33, 102, 172], [146, 197, 222], [247, 247, 247], [244, 165, 130], [178, 24, 43]];
  function srgb(x) {
    x = Math.max(0, Math.min(1, x));
    return 255 * (x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055);
  }
  function axes(ctx, box, xticks, yticks, xlab, ylab) {
    ctx.strokeStyle = '#999'; ctx.fillStyle = '#333'; ctx.font = '11px sans-serif'; ctx.lineWidth = 1;
    ctx.strokeRect(box.x, box.y, box.w, box.h);
    ctx.textAlign = 'center';
    xticks.forEach(function (t) { ctx.fillText(t[1], t[0], box.y + box.h + 14); });
    ctx.textAlign = 'right';
    yticks.forEach(function (t) { ctx.fillText(t[1], box.x - 4, t[0] + 4); });
    ctx.textAlign = 'center'; ctx.fillText(xlab, box.x + box.w / 2, box.y + box.h + 30);
    ctx.save(); ctx.translate(12, box.y + box.h / 2); ctx.rotate(-HALF_PI); ctx.fillText(ylab, 0, 0); ctx.restore();
  }
  // Sources hidden from the incidence plot (click a legend entry to hide or show it).
  var hidden = SRC.map(function () { return false; });
  function legend(el) {
    el.innerHTML = '';
    SRC.forEach(function (s, k) {
      var sp = document.createElement('span');
      sp.style.cursor = 'pointer';
      sp.title = 'click to hide or show';
      sp.addEventListener('click', function () {
        hidden[k] = !hidden[k]; sp.style.opacity = hidden[k] ? 0.35 : 1; drawIncidence();
      });
      sp.innerHTML = '<i class="swatch" style="background:' + s.colour + '"></i>';
      sp.appendChild(document.createTextNode(s.label));
      el.appendChild(sp);
    });
  }
  function fmt(x) { return x === null ? '–' : (Math.abs(x) >= 1e-3 && Math.abs(x) < 1e4 ? x.toPrecision(4) : x.toExponential(3)); }

  // --- incidence plane ---
  var drawIncidence = timed('incidence', function () {
    var ti = +$('inc-theta').value, phi = +$('inc-phi').value, ch = +$('inc-channel').value;
    var log = $('inc-scale').value === 'log';
    $('inc-theta-out').textContent = ti + '°'; $('inc-phi-out').textContent = phi + '°';
    var wi = sph(rad(ti), PI), pts = [], vals = SRC.map(function () { return []; });
    var o = [0, 0, 0], vmax = 0;
    for (var k = -178; k <= 178; k++) {
      var to = k / 2, wo = sph(rad(Math.abs(to)), rad(to < 0 ? phi + 180 : phi));
      pts.push({ theta_o: to, wi: wi, wo: wo });
      for (var s = 0; s < SRC.length; s++) {
        var v = lookup(s, wi, wo, o) ? [o[0], o[1], o[2]] : null;
        vals[s].push(v);
        if (v && !hidden[s] && v[ch] > vmax) vmax = v[ch];
      }
    }
    var cv = $('inc-canvas'), ctx = cv.getContext('2d');
    ctx.clearRect(0, 0, cv.width, cv.height);
    var box = { x: 64, y: 10, w: cv.width - 80, h: cv.height - 54 };
    var ymax = vmax > 0 ? vmax : 1, ylo = log ? Math.log10(ymax) - 4 : 0, yhi = log ? Math.log10(ymax) + 0.1 : ymax * 1.05;
    function X(to) { return box.x + (to + 90) / 180 * box.w; }
    function Y(v) {
      var y = log ? Math.log10(Math.max(v, Math.pow(10, ylo))) : v;
      return box.y + box.h - (y - ylo) / (yhi - ylo) * box.h;
    }
    var xt = [-90, -60, -30, 0, 30, 60, 90].map(function (d) { return [X(d), d + '°']; });
    var yt = [];
    for (var q = 0; q <= 4; q++) {
      var yv = ylo + q / 4 * (yhi - ylo);
      yt.push([box.y + box.h - q / 4 * box.h, log ? fmt(Math.pow(10, yv)) : fmt(yv)]);
    }
    axes(ctx, box, xt, yt, 'θo (signed: φ side > 0)', 'f_r (1/sr), ' + (log ? 'log' : 'linear'));
    ctx.setLineDash([4, 4]); ctx.strokeStyle = '#bbb';
    ctx.beginPath(); ctx.moveTo(X(ti), box.y); ctx.lineTo(X(ti), box.y + box.h); ctx.stroke();
    ctx.setLineDash([]);
    ctx.save(); ctx.beginPath(); ctx.rect(box.x, box.y, box.w, box.h); ctx.clip();
    for (s = 0; s < SRC.length; s++) {
      if (hidden[s]) continue;
      ctx.strokeStyle = SRC[s].colour; ctx.lineWidth = s === 0 ? 2.5 : 1.5;
      ctx.beginPath(); var pen = false;
      for (var p = 0; p < pts.length; p++) {
        var val = vals[s][p];
        if (!val || (log && !(val[ch] > 0))) { pen = false; continue; }
        if (pen) ctx.lineTo(X(pts[p].theta_o), Y(val[ch])); else ctx.moveTo(X(pts[p].theta_o), Y(val[ch]));
        pen = true;
      }
      ctx.stroke();
    }
    ctx.restore();
    hook.plotted.incidence = { theta_i: ti, phi: phi, channel: ch, scale: log ? 'log' : 'linear', hidden: hidden.slice(), points: pts, values: vals };
  });

  // --- θh–θd slice ---
  var SW = 180, sliceImg = null, SLICE_BOX = { x: 52, y: 10, w: 360, h: 360 };
  function fromHalfDiff(th, td, pd) {
    var d = sph(td, pd), c = Math.cos(th), s = Math.sin(th);
    var wi = [d[0] * c + d[2] * s, d[1], d[2] * c - d[0] * s];
    var h = [s, 0, c], dot = 2 * (wi[0] * h[0] + wi[2] * h[2]);
    return [wi, [dot * h[0] - wi[0], -wi[1], dot * h[2] - wi[2]]];
  }
  // The value at pixel (x, y) of the slice: looked up at the cell's angles directly
  // (no round trip through the directions), below the horizon left out as lookup does.
  var SHD = [0, 0, 0];
  function byAngles(k, w, o) {
    if (!(w[0][2] > 0 && w[1][2] > 0)) return false;
    coordsOf(SHD, UVW);
    return interpolate(GRIDS[k], UVW[0], UVW[1], UVW[2], o);
  }
  function sliceAt(x, y, pd, s, ch, ratio, o, r) {
    var th = Math.pow((x + 0.5) / SW, 2) * HALF_PI, td = (y + 0.5) / SW * HALF_PI;
    var w = fromHalfDiff(th, td, pd);
    SHD[0] = th; SHD[1] = td; SHD[2] = pd;
    var ok = byAngles(s, w, o);
    var ref = ratio ? byAngles(0, w, r) : true;
    return { th: th, td: td, wi: w[0], wo: w[1], ok: ok && ref, v: ok ? o[ch] : null, ref: ratio && ref ? r[ch] : null };
  }
  var drawSlice = timed('slice', function () {
    var pdDeg = +$('slice-phi').value, pd = rad(pdDeg), s = +$('slice-source').value;
    var ch = +$('slice-channel').value, ratio = $('slice-mode').value === 'ratio';
    $('slice-phi-out').textContent = pdDeg + '°';
    var o = [0, 0, 0], r = [0, 0, 0], z = new Float64Array(SW * SW), vmax = -Infinity;
    for (var y = 0; y < SW; y++) for (var x = 0; x < SW; x++) {
      var c = sliceAt(x, y, pd, s, ch, ratio, o, r), v = NaN;
      if (c.ok && c.v > 0 && (!ratio || c.ref > 0)) v = ratio ? Math.log10(c.v / c.ref) : Math.log10(c.v);
      z[y * SW + x] = v;
      if (v > vmax) vmax = v;
    }
    var img = new ImageData(SW, SW), px = img.data;
    for (var i = 0; i < SW * SW; i++) {
      var val = z[i];
      if (val !== val) { px[4 * i] = 200; px[4 * i + 1] = 200; px[4 * i + 2] = 200; }
      else if (ratio) ramp(DIVERGING, (val + 1) / 2, px, 4 * i);
      else ramp(VIRIDIS, (val - (vmax - 4)) / 4, px, 4 * i);
      px[4 * i + 3] = 255;
    }
    var off = document.createElement('canvas'); off.width = SW; off.height = SW;
    off.getContext('2d').putImageData(img, 0, 0);
    var cv = $('slice-canvas'), ctx = cv.getContext('2d'), B = SLICE_BOX;
    ctx.clearRect(0, 0, cv.width, cv.height);
    ctx.imageSmoothingEnabled = false; ctx.drawImage(off, B.x, B.y, B.w, B.h);
    // Axes: θh on MERL's √ axis, θd linear; the colour bar on the right.
    var xt = [0, 1, 5, 10, 20, 45, 90].map(function (d) { return [B.x + Math.sqrt(d / 90) * B.w, d + '°']; });
    var yt = [0, 30, 60, 90].map(function (d) { return [B.y + d / 90 * B.h, d + '°']; });
    axes(ctx, B, xt, yt, 'θh (√ axis)', 'θd');
    var bx = B.x + B.w + 14, bar = ctx.createImageData(1, 1);
    for (var k = 0; k < B.h; k++) {
      var t = 1 - k / (B.h - 1);
      if (ratio) ramp(DIVERGING, t, bar.data, 0); else ramp(VIRIDIS, t, bar.data, 0);
      ctx.fillStyle = 'rgb(' + bar.data[0] + ',' + bar.data[1] + ',' + bar.data[2] + ')';
      ctx.fillRect(bx, B.y + k, 14, 1);
    }
    ctx.fillStyle = '#333'; ctx.textAlign = 'left';
    var top = ratio ? '+1 (×10)' : fmt(Math.pow(10, vmax)), mid = ratio ? '0' : fmt(Math.pow(10, vmax - 2));
    var bottom = ratio ? '−1 (÷10)' : fmt(Math.pow(10, vmax - 4));
    ctx.fillText(top, bx + 18, B.y + 8); ctx.fillText(mid, bx + 18, B.y + B.h / 2 + 4); ctx.fillText(bottom, bx + 18, B.y + B.h);
    sliceImg = { vmax: vmax, pd: pd };
    hook.plotted.slice = { phi_d: pdDeg, source: s, channel: ch, mode: ratio ? 'ratio' : 'value', log10_max: vmax, cursor: hook.plotted.slice ? hook.plotted.slice.cursor : null };
  });
  function sliceCursor(ev) {
    var cv = $('slice-canvas'), b = cv.getBoundingClientRect(), B = SLICE_BOX;
    var cx = (ev.clientX - b.left) * cv.width / b.width, cy = (ev.clientY - b.top) * cv.height / b.height;
    var x = Math.floor((cx - B.x) / B.w * SW), y = Math.floor((cy - B.y) / B.h * SW);
    if (x < 0 || y < 0 || x >= SW || y >= SW || !sliceImg) return;
    var s = +$('slice-source').value, ch = +$('slice-channel').value, o = [0, 0, 0], r = [0, 0, 0];
    var c = sliceAt(x, y, sliceImg.pd, s, ch, true, o, r);
    var val = lookup(s, c.wi, c.wo, o) ? [o[0], o[1], o[2]] : null;
    var ref = lookup(0, c.wi, c.wo, r) ? [r[0], r[1], r[2]] : null;
    var text = 'θh ' + (c.th * 180 / PI).toFixed(2) + '°  θd ' + (c.td * 180 / PI).toFixed(2) + '°  φd ' +
      (sliceImg.pd * 180 / PI).toFixed(0) + '°  ' + SRC[s].label + ': ' + (val ? val.map(fmt).join(', ') : 'no value');
    if (s !== 0) text += '  ' + SRC[0].label + ': ' + (ref ? ref.map(fmt).join(', ') : 'no value') +
      (val && ref && ref[ch] > 0 && val[ch] > 0 ? '  log10 ratio ' + Math.log10(val[ch] / ref[ch]).toFixed(3) : '');
    $('slice-readout').textContent = text;
    hook.plotted.slice.cursor = { theta_h: c.th, theta_d: c.td, phi_d: sliceImg.pd, wi: c.wi, wo: c.wo, value: val, reference: ref };
  }

  // --- lit sphere ---
  var S = 256, light = [0.5, 0.5, Math.SQRT1_2];
  function sphereRadiance(k, exposure, out) {
    var n = new Float32Array(S * S * 3).fill(NaN), o = [0, 0, 0], wi = [0, 0, 0], wo = [0, 0, 0];
    for (var y = 0; y < S; y++) for (var x = 0; x < S; x++) {
      var nx = (x + 0.5) / S * 2 - 1, ny = 1 - (y + 0.5) / S * 2, r2 = nx * nx + ny * ny;
      if (r2 >= 1) continue;
      var nz = Math.sqrt(1 - r2), i3 = 3 * (y * S + x);
      var cosI = nx * light[0] + ny * light[1] + nz * light[2];
      if (!(cosI > 0)) { n[i3] = 0; n[i3 + 1] = 0; n[i3 + 2] = 0; continue; }
      // A tangent frame about the normal (any: the grids are isotropic).
      var ax = Math.abs(nx) < 0.9 ? 1 : 0, ay = 1 - ax, an = ax * nx + ay * ny;
      var tx = ax - an * nx, ty = ay - an * ny, tz = -an * nz, tl = Math.sqrt(tx * tx + ty * ty + tz * tz);
      tx /= tl; ty /= tl; tz /= tl;
      var bx = ny * tz - nz * ty, by = nz * tx - nx * tz, bz = nx * ty - ny * tx;
      wi[0] = light[0] * tx + light[1] * ty + light[2] * tz;
      wi[1] = light[0] * bx + light[1] * by + light[2] * bz; wi[2] = cosI;
      wo[0] = tz; wo[1] = bz; wo[2] = nz;
      var scale = cosI * PI * exposure;
      if (lookup(k, wi, wo, o)) { n[i3] = o[0] * scale; n[i3 + 1] = o[1] * scale; n[i3 + 2] = o[2] * scale; }
      else { n[i3] = 0; n[i3 + 1] = 0; n[i3 + 2] = 0; }
      if (out && out[y * S + x]) out[y * S + x] = { px: [x, y], wi: wi.slice(), wo: wo.slice(), f: lookup(k, wi, wo, o) ? o.slice() : null, cos_i: cosI };
    }
    return n;
  }
  function paint(cv, rad3, diffWith) {
    var ctx = cv.getContext('2d'), img = ctx.createImageData(S, S), px = img.data;
    for (var i = 0; i < S * S; i++) {
      var a = rad3[3 * i];
      if (a !== a) { px[4 * i] = px[4 * i + 1] = px[4 * i + 2] = 255; px[4 * i + 3] = 255; continue; }
      if (diffWith) {
        var d = 0;
        for (var c = 0; c < 3; c++) d += srgb(rad3[3 * i + c]) - srgb(diffWith[3 * i + c]);
        d = Math.max(-1, Math.min(1, 4 * d / 3 / 255));
        px[4 * i] = d > 0 ? 255 * d : 0; px[4 * i + 1] = d > 0 ? 140 * d : 80 * -d; px[4 * i + 2] = d < 0 ? 255 * -d : 0;
      } else {
        px[4 * i] = srgb(rad3[3 * i]); px[4 * i + 1] = srgb(rad3[3 * i + 1]); px[4 * i + 2] = srgb(rad3[3 * i + 2]);
      }
      px[4 * i + 3] = 255;
    }
    ctx.putImageData(img, 0, 0);
    ctx.strokeStyle = '#bbb'; ctx.beginPath(); ctx.arc(S / 2, S / 2, S / 2 - 0.5, 0, 2 * PI); ctx.stroke();
  }
  var PROBES = [[128, 128], [96, 160], [160, 96], [200, 128], [128, 60]];
  var drawSphere = timed('sphere', function () {
    var k = +$('sphere-source').value, mode = $('sphere-mode').value, ev = +$('sphere-exposure').value;
    $('sphere-exposure-out').textContent = (ev >= 0 ? '+' : '') + ev + ' EV';
    var exposure = Math.pow(2, ev), probes = new Array(S * S);
    PROBES.forEach(function (p) { probes[p[1] * S + p[0]] = true; });
    var a = sphereRadiance(k, exposure, probes), b = $('sphere-b');
    if (mode === 'single') { paint($('sphere-a'), a); b.style.display = 'none'; }
    else {
      var ref = sphereRadiance(0, exposure, null);
      if (mode === 'side') { paint($('sphere-a'), ref); paint(b, a); b.style.display = ''; }
      else { paint($('sphere-a'), a, ref); b.style.display = 'none'; }
    }
    $('sphere-readout').textContent = 'light (' + light.map(function (x) { return x.toFixed(3); }).join(', ') + '), θ ' +
      (Math.acos(light[2]) * 180 / PI).toFixed(1) + '°';
    hook.plotted.sphere = { source: k, mode: mode, exposure: ev, light: light.slice(),
      probes: PROBES.map(function (p) { return probes[p[1] * S + p[0]]; }).filter(function (p) { return p && p.px; }) };
  });
  function dragLight(ev) {
    if (ev.type !== 'pointerdown' && !(ev.buttons & 1)) return;
    var b = ev.currentTarget.getBoundingClientRect();
    var x = (ev.clientX - b.left) / b.width * 2 - 1, y = 1 - (ev.clientY - b.top) / b.height * 2, r2 = x * x + y * y;
    if (r2 > 0.998) { var r = Math.sqrt(r2 / 0.998); x /= r; y /= r; r2 = 0.998; }
    light = [x, y, Math.sqrt(1 - r2)];
    drawSphere();
  }

  // --- directional albedo ---
  var NS = 40, NPHI = 48, albedoCurve = null;
  // a(θo) = ∫ f cos θi dωi = ∫∫ f ½ d(cos²θi) dφi: midpoint rule in s = cos²θi and φi over
  // [0, π], doubled (f is even in φi for an isotropic source with wo at φ = 0).
  function albedo(k, to) {
    var wo = sph(to, 0), o = [0, 0, 0], acc = [0, 0, 0], w = PI / (NS * NPHI);
    for (var i = 0; i < NS; i++) {
      var mu = Math.sqrt((i + 0.5) / NS), st = Math.sqrt(1 - mu * mu);
      for (var j = 0; j < NPHI; j++) {
        var p = (j + 0.5) / NPHI * PI, wi = [st * Math.cos(p), st * Math.sin(p), mu];
        if (lookup(k, wi, wo, o)) { acc[0] += o[0] * w; acc[1] += o[1] * w; acc[2] += o[2] * w; }
      }
    }
    return acc;
  }
  var drawAlbedo = timed('albedo', function () {
    var t = +$('albedo-theta').value, ch = +$('albedo-channel').value;
    $('albedo-theta-out').textContent = t + '°';
    // The curve is computed once, after the first draw (which shows the chosen θo alone),
    // so that it does not delay the page's first answer to input.
    if (!albedoCurve) {
      albedoCurve = { theta: [], values: SRC.map(function () { return []; }) };
      setTimeout(function () {
        for (var d = 0; d <= 85; d += d < 80 ? 10 : 5) {
          albedoCurve.theta.push(d);
          for (var s = 0; s < SRC.length; s++) albedoCurve.values[s].push(albedo(s, rad(d)));
        }
        hook.albedoCurveReady = true;
        drawAlbedo();
      }, 0);
    }
    var at = SRC.map(function (_, s) { return albedo(s, rad(t)); });
    var cv = $('albedo-canvas'), ctx = cv.getContext('2d');
    ctx.clearRect(0, 0, cv.width, cv.height);
    var box = { x: 64, y: 10, w: cv.width - 80, h: cv.height - 54 }, ymax = 0;
    albedoCurve.values.forEach(function (vs) { vs.forEach(function (v) { ymax = Math.max(ymax, v[ch]); }); });
    at.forEach(function (v) { ymax = Math.max(ymax, v[ch]); });
    ymax = ymax > 0 ? ymax * 1.1 : 1;
    function X(d) { return box.x + d / 90 * box.w; }
    function Y(v) { return box.y + box.h - v / ymax * box.h; }
    axes(ctx, box, [0, 15, 30, 45, 60, 75, 90].map(function (d) { return [X(d), d + '°']; }),
      [0, 1, 2, 3, 4].map(function (q) { return [Y(q / 4 * ymax), fmt(q / 4 * ymax)]; }), 'θo', 'a(θo)');
    ctx.strokeStyle = '#bbb'; ctx.setLineDash([4, 4]);
    ctx.beginPath(); ctx.moveTo(X(t), box.y); ctx.lineTo(X(t), box.y + box.h); ctx.stroke(); ctx.setLineDash([]);
    for (var s2 = 0; s2 < SRC.length; s2++) {
      ctx.strokeStyle = SRC[s2].colour; ctx.fillStyle = SRC[s2].colour; ctx.lineWidth = s2 === 0 ? 2.5 : 1.5;
      ctx.beginPath();
      albedoCurve.theta.forEach(function (d, q) {
        var y = Y(albedoCurve.values[s2][q][ch]); if (q) ctx.lineTo(X(d), y); else ctx.moveTo(X(d), y);
      });
      ctx.stroke();
      ctx.beginPath(); ctx.arc(X(t), Y(at[s2][ch]), 4, 0, 2 * PI); ctx.fill();
    }
    var rows = '<thead><tr><th class="l">source</th><th>R</th><th>G</th><th>B</th></tr></thead><tbody>';
    at.forEach(function (v, s) {
      rows += '<tr><td class="l"><i class="swatch" style="background:' + SRC[s].colour + '"></i>' +
        SRC[s].label.replace(/&/g, '&amp;').replace(/</g, '&lt;') + '</td><td>' + v.map(fmt).join('</td><td>') + '</td></tr>';
    });
    $('albedo-table').innerHTML = rows + '</tbody>';
    hook.plotted.albedo = { theta_o: t, channel: ch, values: at, curve: albedoCurve };
  });

  function wire(ids, draw) {
    ids.forEach(function (id) { $(id).addEventListener('input', draw); $(id).addEventListener('change', draw); });
  }
  wire(['inc-theta', 'inc-phi', 'inc-scale', 'inc-channel'], drawIncidence);
  wire(['slice-phi', 'slice-source', 'slice-mode', 'slice-channel'], drawSlice);
  wire(['sphere-source', 'sphere-mode', 'sphere-exposure'], drawSphere);
  wire(['albedo-theta', 'albedo-channel'], drawAlbedo);
  $('slice-canvas').addEventListener('mousemove', sliceCursor);
  ['sphere-a', 'sphere-b'].forEach(function (id) {
    $(id).addEventListener('pointerdown', dragLight); $(id).addEventListener('pointermove', dragLight);
  });
  legend($('inc-legend'));
  hook.timings.script_start = tStart;
  Promise.all(SRC.map(function (s) { return inflate(s.data); })).then(function (all) {
    hook.timings.inflated = performance.now() - tStart;
    GRIDS = all.map(function (bytes, k) { return decode(SRC[k], bytes); });
    hook.timings.decode = performance.now() - tStart;
    drawIncidence(); drawSlice(); drawSphere(); drawAlbedo();
    hook.timings.load = performance.now();
    hook.ready = true;
    document.documentElement.setAttribute('data-view-ready', 'true');
  }).catch(function (e) {
    console.error('brdfkit view: the embedded values cannot be read: ' + e);
  });
})();
