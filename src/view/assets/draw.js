// femto view: the page's drawings that are not the frame itself: the light curve under the
// time slider, the wavelength and isochrone legends, the probe's time profiles and its
// mark on the picture. Each function draws from the numbers it is given and keeps no state.
'use strict';

const femtoDraw = (() => {
  // The light curve of the current view: its samples (filled), the lit range (shaded) and
  // the time cursor; `range` is [t0, t1], the slider's range.
  function lightCurve(c, curve, range, t) {
    const g = c.getContext('2d');
    g.clearRect(0, 0, c.width, c.height);
    if (!curve || !curve.t_ps.length) return;
    const [t0, t1] = range;
    const x = (tt) => (tt - t0) / (t1 - t0) * c.width;
    const top = Math.max(...curve.mean) || 1;
    if (curve.lit_range_ps) {
      const [a, b] = curve.lit_range_ps;
      g.fillStyle = 'rgba(240,200,80,0.18)';
      g.fillRect(x(a), 0, x(b) - x(a), c.height);
    }
    g.beginPath();
    g.moveTo(0, c.height);
    curve.t_ps.forEach((tt, k) => g.lineTo(x(tt), c.height - 2 - (c.height - 4) * curve.mean[k] / top));
    g.lineTo(c.width, c.height);
    g.fillStyle = 'rgba(140,196,255,0.45)';
    g.fill();
    g.strokeStyle = '#f0c850';
    g.lineWidth = 2;
    const xt = x(t);
    g.beginPath(); g.moveTo(xt, 0); g.lineTo(xt, c.height); g.stroke();
  }

  // The colour the legend draws light of `nm` in: the renderer's colour inside the visible
  // range, grey outside it.
  function spectrumColour(info, nm) {
    const [v0, v1] = info.visible_nm;
    if (nm < v0 || nm > v1) return '#7a7a7a';
    const s = info.spectrum;
    const k = Math.max(0, Math.min(s.length - 1, Math.round((nm - s[0].nm) / (s[1].nm - s[0].nm))));
    return `rgb(${s[k].srgb8.join(',')})`;
  }

  // The wavelength legend: the spectrum, the laser (black tick) and the received range
  // (white bar), and a sentence that is true for this frame.
  function spectrum(c, textEl, info, h, doppler, falseColour) {
    if (falseColour) { spectrumFalse(c, textEl, info, h, doppler); return; }
    const g = c.getContext('2d');
    const s = info.spectrum;
    const [a, b] = [s[0].nm, s[s.length - 1].nm];
    const x = (nm) => Math.max(0, Math.min(c.width, (nm - a) / (b - a) * c.width));
    for (const e of s) { g.fillStyle = spectrumColour(info, e.nm); g.fillRect(x(e.nm - 2.5), 0, x(e.nm + 2.5) - x(e.nm - 2.5) + 1, 12); }
    g.clearRect(0, 12, c.width, c.height - 12);
    const [v0, v1] = info.visible_nm;
    const visible = (nm) => Math.min(v1, Math.max(v0, nm));
    const [lo, hi] = doppler ? [h.doppler_min * h.laser_nm, h.doppler_max * h.laser_nm] : [visible(h.laser_nm), visible(h.laser_nm)];
    g.fillStyle = '#ffffff';
    g.fillRect(x(lo), 13, Math.max(2, x(hi) - x(lo)), 8);
    g.font = '10px sans-serif'; g.fillStyle = '#000';
    g.fillText('UV: grey', 4, 10);
    g.fillText('IR: grey', c.width - 48, 10);
    g.fillRect(x(h.laser_nm) - 1, 0, 3, 12);
    g.fillStyle = '#fff'; g.fillRect(x(h.laser_nm), 0, 1, 12);
    const band = (nm) => nm < v0 ? 'UV' : nm > v1 ? 'IR' : 'visible';
    const shifted = doppler && Math.abs(h.doppler_max - 1) + Math.abs(h.doppler_min - 1) > 1e-6;
    const drawn = visible(h.laser_nm);
    let text = `laser ${h.laser_nm.toFixed(0)} nm (${band(h.laser_nm)}, black tick). `;
    if (!doppler) {
      text += 'Doppler off: every pixel in the laser\'s colour' +
        (drawn !== h.laser_nm ? ` (drawn at ${drawn} nm, the nearest visible colour).` : '.');
    } else if (!shifted) {
      text += 'At rest nothing is shifted: every pixel receives the laser\'s own wavelength' +
        (band(h.laser_nm) !== 'visible' ? `, which is ${band(h.laser_nm)}: drawn grey.` : '.');
    } else {
      text += `Received ${lo.toFixed(0)}-${hi.toFixed(0)} nm (white bar; ${band(lo)}${band(hi) !== band(lo) ? ' to ' + band(hi) : ''}).`;
      if ([lo, hi].some((nm) => nm < v0 || nm > v1)) text += ` Light shifted outside ${v0}-${v1} nm is drawn grey.`;
    }
    textEl.textContent = text;
    textEl.dataset.range = `${lo.toFixed(1)}-${hi.toFixed(1)}`;
  }

  // The legend in false colour: the bar is the drawn colours, the laser's own light at
  // 550 nm, the received range at D times that.
  function spectrumFalse(c, textEl, info, h, doppler) {
    const g = c.getContext('2d');
    const s = info.spectrum;
    const [a, b] = [s[0].nm, s[s.length - 1].nm];
    const x = (nm) => Math.max(0, Math.min(c.width, (nm - a) / (b - a) * c.width));
    for (const e of s) { g.fillStyle = spectrumColour(info, e.nm); g.fillRect(x(e.nm - 2.5), 0, x(e.nm + 2.5) - x(e.nm - 2.5) + 1, 12); }
    g.clearRect(0, 12, c.width, c.height - 12);
    const base = info.false_colour_laser_nm;
    const [lo, hi] = doppler ? [h.doppler_min * base, h.doppler_max * base] : [base, base];
    g.fillStyle = '#ffffff';
    g.fillRect(x(lo), 13, Math.max(2, x(hi) - x(lo)), 8);
    g.fillStyle = '#000'; g.fillRect(x(base) - 1, 0, 3, 12);
    g.fillStyle = '#fff'; g.fillRect(x(base), 0, 1, 12);
    const shifted = doppler && Math.abs(h.doppler_max - 1) + Math.abs(h.doppler_min - 1) > 1e-6;
    textEl.textContent = `False colour: the laser's ${h.laser_nm.toFixed(0)} nm drawn as ${base} nm (black tick); ` +
      (!doppler ? 'Doppler off: every pixel in that colour.' : !shifted ? 'at rest nothing is shifted: every pixel in that colour.' : doppler
        ? `light received at D times it drawn at D x ${base} nm (white bar: D ${h.doppler_min.toFixed(3)}-${h.doppler_max.toFixed(3)}, ` +
          `received ${(h.doppler_min * h.laser_nm).toFixed(0)}-${(h.doppler_max * h.laser_nm).toFixed(0)} nm).`
        : 'Doppler off: every pixel in that colour.');
    textEl.dataset.range = `${(h.doppler_min * h.laser_nm).toFixed(1)}-${(h.doppler_max * h.laser_nm).toFixed(1)}`;
  }

  // The isochrone legend: the colour ramp of arrival times with its contours, labelled at
  // both ends and in the middle, and the frame's reception time marked.
  function isochrones(c, textEl, iso, t) {
    const g = c.getContext('2d');
    const bar = 12;
    g.clearRect(0, 0, c.width, c.height);
    // views::hue_ramp: blue, cyan, green, yellow, red.
    const grad = g.createLinearGradient(0, 0, c.width, 0);
    ['#0000ff', '#00ffff', '#00ff00', '#ffff00', '#ff0000'].forEach((col, k) => grad.addColorStop(k / 4, col));
    g.fillStyle = grad;
    g.fillRect(0, 0, c.width, bar);
    g.fillStyle = 'rgba(0,0,0,0.85)';
    const span = iso.t_max_ps - iso.t_min_ps;
    const x = (tt) => (tt - iso.t_min_ps) / span * c.width;
    for (let tt = Math.ceil(iso.t_min_ps / iso.contour_ps) * iso.contour_ps; tt <= iso.t_max_ps; tt += iso.contour_ps) {
      g.fillRect(x(tt) - 1, 0, 2, bar);
    }
    g.font = '10px sans-serif'; g.fillStyle = '#cfd6df';
    g.textBaseline = 'top';
    g.textAlign = 'left'; g.fillText(`${iso.t_min_ps.toFixed(0)} ps`, 2, bar + 1);
    g.textAlign = 'center'; g.fillText(`${((iso.t_min_ps + iso.t_max_ps) / 2).toFixed(0)} ps`, c.width / 2, bar + 1);
    g.textAlign = 'right'; g.fillText(`${iso.t_max_ps.toFixed(0)} ps`, c.width - 2, bar + 1);
    if (t >= iso.t_min_ps && t <= iso.t_max_ps) {
      g.fillStyle = '#fff';
      g.fillRect(x(t) - 1, 0, 3, bar);
    }
    textEl.textContent =
      `arrival of the laser's direct light at the camera, ${iso.t_min_ps.toFixed(0)} ps (blue) to ` +
      `${iso.t_max_ps.toFixed(0)} ps (red), contours every ${Number(iso.contour_ps.toPrecision(3))} ps; ` +
      'white tick: this frame\'s time; mid-grey: no direct pulse; black: no surface. From the mesh, not the cube.';
  }

  // The probe's two profiles: the capture pixel's signal in world time and what this pixel
  // receives at each reception time, each scaled to its own peak, with the current time.
  function probePlot(c, probe, t) {
    const g = c.getContext('2d');
    g.clearRect(0, 0, c.width, c.height);
    g.fillStyle = '#101216'; g.fillRect(0, 0, c.width, c.height);
    const series = [[probe.capture, '#f0a040'], [probe.received, '#8cc4ff']].filter(([p]) => p && p.t_ps.length);
    if (!series.length) return;
    const ts = series.flatMap(([p]) => [p.t_ps[0], p.t_ps[p.t_ps.length - 1]]).concat([t]);
    const t0 = Math.min(...ts), t1 = Math.max(...ts);
    const x = (tt) => 4 + (tt - t0) / ((t1 - t0) || 1) * (c.width - 8);
    for (const [p, colour] of series) {
      const top = Math.max(...p.value.map(Math.abs)) || 1;
      g.strokeStyle = colour; g.lineWidth = 1.5;
      g.beginPath();
      p.t_ps.forEach((tt, k) => {
        const y = c.height - 14 - (c.height - 20) * Math.max(0, p.value[k]) / top;
        if (k) g.lineTo(x(tt), y); else g.moveTo(x(tt), y);
      });
      g.stroke();
    }
    g.fillStyle = '#f0c850'; g.fillRect(x(t) - 1, 0, 2, c.height - 12);
    g.font = '10px sans-serif'; g.fillStyle = '#9fb3c8'; g.textBaseline = 'bottom';
    g.textAlign = 'left'; g.fillText(`${t0.toFixed(0)} ps`, 2, c.height);
    g.textAlign = 'right'; g.fillText(`${t1.toFixed(0)} ps`, c.width - 2, c.height);
  }

  // A crosshair over the probed pixel, on the overlay canvas the size of the frame.
  function probeMark(c, pixel, width, height) {
    if (c.width !== width || c.height !== height) { c.width = width; c.height = height; }
    const g = c.getContext('2d');
    g.clearRect(0, 0, c.width, c.height);
    if (!pixel) return;
    const [i, j] = pixel;
    const r = Math.max(6, Math.round(width / 80));
    g.strokeStyle = '#ffe066'; g.lineWidth = Math.max(1, width / 640);
    g.beginPath();
    g.moveTo(i + 0.5 - 2 * r, j + 0.5); g.lineTo(i + 0.5 - r / 2, j + 0.5);
    g.moveTo(i + 0.5 + r / 2, j + 0.5); g.lineTo(i + 0.5 + 2 * r, j + 0.5);
    g.moveTo(i + 0.5, j + 0.5 - 2 * r); g.lineTo(i + 0.5, j + 0.5 - r / 2);
    g.moveTo(i + 0.5, j + 0.5 + r / 2); g.lineTo(i + 0.5, j + 0.5 + 2 * r);
    g.stroke();
  }

  return { lightCurve, spectrum, isochrones, probePlot, probeMark };
})();
