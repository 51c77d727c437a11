// rockdove film bake: the thin-film colour LUT over (cos theta, thickness) baked in the page, with the physics of
// pipeline/rockdove/lut (docs/viewer.md, "How the page bakes"). Exact Airy reflectance of one film (s and p,
// complex index n + ik; Born & Wolf, Principles of Optics, 7th ed., sec. 7.6.1), unpolarised (mean of s and p),
// integrated against the CIE 1931 2 degree observer under D65 into linear Rec.709 (a perfect reflector is white
// (1, 1, 1)). Every table it integrates with is rockdove.lut's own, written by rockdove.web.viewer.film_tables
// (the 0.1 nm reference weights, the Fourier table G, the Chebyshev product-integration weights) with the bakers'
// constants, so the physics has one source. Three routes, as rockdove.lut.bake's "auto":
//   - "fourier": a real, non-dispersive film (k = 0, no total internal reflection): the closed-form Fourier series
//     R(phi) = c0 + 2 sum_m c1 rho^(m-1) cos(m phi), colour = c0 W0 + 2 sum_m c_m G(m OPD) (rockdove.lut.fourier);
//   - "quadrature": a real, dispersive film: product integration in wavenumber on mapped Chebyshev nodes, the
//     truncated Poisson series near grazing and Chebyshev interpolation across the angles away from it
//     (rockdove.lut.quadrature);
//   - "complex": absorbing films (k > 0) and total internal reflection: the same product integration of the complex
//     Airy reflectance, its node count from the resonances' damping; columns whose resonances are too sharp for
//     the node ladder (or whose film index crosses the critical angle within the spectrum) are integrated on the
//     0.1 nm grid of the exact reference (rockdove.lut.reference).
// Layout of the result (rockdove.lut.table): rgb[(i * angles + j) * 3 + c], thickness node i (uniform over the
// range), angle node j (cos theta_j = (j / (angles - 1)) ** gamma). Runs in the page (window.RockdoveFilmBake).
(function (root) {
  "use strict";

  const TWO_PI = 2 * Math.PI, FOUR_PI = 4 * Math.PI;

  function decode(b64, Type) {
    const s = atob(b64), bytes = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) { bytes[i] = s.charCodeAt(i); }
    return new Type(bytes.buffer, 0, bytes.byteLength / Type.BYTES_PER_ELEMENT);
  }

  // The tables of rockdove.web.viewer.film_tables, decoded once.
  function Tables(data) {
    this.c = data.constants;
    [this.lamLo, this.lamHi] = data.wavelength_range_nm;
    this.sLo = 1 / this.lamHi;
    this.sHi = 1 / this.lamLo;
    const wRef = decode(data.reference_weights, Float64Array);
    const nRef = wRef.length / 3;
    this.refLam = new Float64Array(nRef);
    for (let i = 0; i < nRef; i++) { this.refLam[i] = this.lamLo + (this.lamHi - this.lamLo) * i / (nRef - 1); }
    this.refW = wRef;
    this.gStep = data.g_step_nm;
    this.g = decode(data.g, Float32Array);
    const nG = this.g.length / 3;
    this.gN = nG;
    this.gTail = new Float64Array(nG);  // max over x' >= x of max_channel |G(x')|: the truncation's envelope
    let run = 0;
    for (let k = nG - 1; k >= 0; k--) {
      run = Math.max(run, Math.abs(this.g[3 * k]), Math.abs(this.g[3 * k + 1]), Math.abs(this.g[3 * k + 2]));
      this.gTail[k] = run;
    }
    this.w0 = [this.g[0], this.g[1], this.g[2]];
    this.ladder = data.ladder;
    const lam = decode(data.ladder_wavelength_nm, Float64Array), w = decode(data.ladder_weights, Float32Array);
    this.nodes = {};
    let off = 0;
    for (const n of this.ladder) {
      const white = [0, 0, 0];
      const wn = new Float64Array(w.subarray(3 * off, 3 * (off + n)));
      for (let k = 0; k < n; k++) { for (let c = 0; c < 3; c++) { white[c] += wn[3 * k + c]; } }
      this.nodes[n] = { lam: lam.subarray(off, off + n), w: wn, white };
      off += n;
    }
    this.ref = { lam: this.refLam, w: this.refW, white: [0, 1, 2].map((c) => {
      let s = 0;
      for (let k = 0; k < nRef; k++) { s += wRef[3 * k + c]; }
      return s;
    }) };
  }

  // G(x) by 4-point Lagrange interpolation on the table (G is even; 0 beyond its end), added times `coef` to out.
  function addG(T, x, coef, out) {
    const f = x / T.gStep;
    const k = Math.floor(f);
    if (k + 2 >= T.gN) { return; }
    const t = f - k, g = T.g;
    const wm = -t * (t - 1) * (t - 2) / 6, w0 = (t + 1) * (t - 1) * (t - 2) / 2;
    const w1 = -(t + 1) * t * (t - 2) / 2, w2 = (t + 1) * t * (t - 1) / 6;
    const km = 3 * (k === 0 ? 1 : k - 1), k0 = 3 * k;
    out[0] += coef * (wm * g[km] + w0 * g[k0] + w1 * g[k0 + 3] + w2 * g[k0 + 6]);
    out[1] += coef * (wm * g[km + 1] + w0 * g[k0 + 1] + w1 * g[k0 + 4] + w2 * g[k0 + 7]);
    out[2] += coef * (wm * g[km + 2] + w0 * g[k0 + 2] + w1 * g[k0 + 5] + w2 * g[k0 + 8]);
  }

  // Smallest grid x (nm) from which |G| <= level for good (rockdove.lut.fourier.GTable.first_x_below).
  function firstXBelow(T, level) {
    let lo = 0, hi = T.gN;  // first k with tail[k] <= level (tail is non-increasing)
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (T.gTail[mid] <= level) { hi = mid; } else { lo = mid + 1; }
    }
    return lo * T.gStep;
  }

  // Terms M of the Fourier series (rockdove.lut.fourier.n_terms_needed): the smaller of the geometric remainder
  // bound and the decay of G; a huge value where the series does not end (OPD -> 0 with |rho| -> 1).
  function termsNeeded(T, c1, rho, opd, tol) {
    c1 = Math.abs(c1);
    const r = Math.abs(rho);
    if (c1 === 0) { return 0; }
    const scale = 2 * c1;
    const ratio = tol * (1 - r) / (scale * T.gTail[0]);
    const mGeom = ratio >= 1 ? 0 : (r > 0 ? Math.ceil(Math.log(ratio) / Math.log(r)) : 1);
    const mDead = opd > 0 ? Math.ceil(firstXBelow(T, tol / scale) / opd) - 1 : Infinity;
    const m = Math.min(mGeom, Math.max(mDead, 0));
    return Number.isNaN(m) ? 0 : Math.min(m, 2 ** 40);
  }

  // Fourier coefficients (c0, c1, rho) of the real Airy reflectance (rockdove.lut.fourier.airy_fourier_coefficients).
  function airyFourier(a, b) {
    const a2 = a * a, b2 = b * b, den = 1 - a2 * b2;
    if (den <= 1e-300) { return [1, 0, -a * b]; }
    return [(a2 + b2 - 2 * a2 * b2) / den, a * b * (1 - a2) * (1 - b2) / den, -a * b];
  }

  // n_j cos theta_j from the incident side (Snell), real: sqrt((n_j - n_a)(n_j + n_a) + (n_a cos_a)^2).
  function qReal(nj, na, cosA) {
    return nj === na ? na * cosA : Math.sqrt((nj - na) * (nj + na) + (na * cosA) * (na * cosA));
  }
  function ratio(num, den) { return den === 0 ? 0 : num / den; }

  // Real Fresnel amplitude coefficients a = r_ab, b = r_bc (s, p) and q_b = n_b cos theta_b.
  function realInterfaces(na, nb, nc, cosA) {
    const qb = qReal(nb, na, cosA), qc = qReal(nc, na, cosA), x = na * cosA;
    return {
      qb,
      as: ratio(x - qb, x + qb), bs: ratio(qb - qc, qb + qc),
      ap: ratio(nb * nb * cosA - na * qb, nb * nb * cosA + na * qb),
      bp: ratio(nc * nc * qb - nb * nb * qc, nc * nc * qb + nb * nb * qc),
    };
  }

  // Complex: index nb = (nr + i k) of the film, real na, nc; returns q_b and the four coefficients as [re, im].
  function csqrt(re, im) {  // the branch Im >= 0 (a decaying wave)
    const r = Math.hypot(re, im);
    let a = Math.sqrt(Math.max(0, (r + re) / 2)), b = Math.sqrt(Math.max(0, (r - re) / 2));
    if (im < 0) { b = -b; }
    if (b < 0 || (b === 0 && a < 0)) { a = -a; b = -b; }
    return [a, b];
  }
  function cdiv(ar, ai, br, bi) {
    if (br === 0 && bi === 0) { return [0, 0]; }
    const m = Math.max(Math.abs(br), Math.abs(bi));
    const xr = br / m, xi = bi / m, d = xr * xr + xi * xi;
    const nr = ar / m, ni = ai / m;
    return [(nr * xr + ni * xi) / d, (ni * xr - nr * xi) / d];
  }
  function complexInterfaces(na, nr, k, nc, cosA) {
    const x = na * cosA, x2 = x * x;
    const nb2r = nr * nr - k * k, nb2i = 2 * nr * k;  // n_b^2
    const [qbr, qbi] = (k === 0 && nr === na) ? [x, 0] : csqrt(nb2r - na * na + x2, nb2i);
    const [qcr, qci] = nc === na ? [x, 0] : csqrt((nc - na) * (nc + na) + x2, 0);
    const nc2 = nc * nc;
    const as = cdiv(x - qbr, -qbi, x + qbr, qbi);
    const bs = cdiv(qbr - qcr, qbi - qci, qbr + qcr, qbi + qci);
    // p: (n_b^2 cos_a - n_a q_b) / (n_b^2 cos_a + n_a q_b), (n_c^2 q_b - n_b^2 q_c) / (n_c^2 q_b + n_b^2 q_c)
    const ap = cdiv(nb2r * cosA - na * qbr, nb2i * cosA - na * qbi, nb2r * cosA + na * qbr, nb2i * cosA + na * qbi);
    const t1r = nc2 * qbr, t1i = nc2 * qbi;
    const t2r = nb2r * qcr - nb2i * qci, t2i = nb2r * qci + nb2i * qcr;
    const bp = cdiv(t1r - t2r, t1i - t2i, t1r + t2r, t1i + t2i);
    return { qbr, qbi, as, bs, ap, bp };
  }

  function filmIndex(film, lam) { return film.cauchy_a + film.cauchy_b_nm2 / (lam * lam); }

  // ------------------------------------------------------------------------------------------------ the routes
  function route(film) {
    const nbMin = filmIndex(film, 780), na = film.n_incident, nc = film.n_substrate;
    if (film.k !== 0 || na > Math.min(nbMin, nc)) { return "complex"; }
    return film.cauchy_b_nm2 === 0 ? "fourier" : "quadrature";
  }

  // Rows of thicknesses: `d` (all rows, uniform) or a subset `rows` of them. For a sample of phase rate k (rad per
  // nm of film) the rows' phases d_i k are stepped by one rotation per row where the rows are consecutive, instead of
  // a sine and a cosine each (relative drift ~1e-16 per row), and evaluated afresh where they are not.
  function Rows(d, rows) {
    this.d = d;
    this.rows = rows || Array.from({ length: d.length }, (_, i) => i);
    this.n = this.rows.length;
    this.step = d.length > 1 ? d[1] - d[0] : 0;
    this.acc = new Float64Array(3 * this.n);
  }
  Rows.prototype.flush = function (out, nA, col) {
    for (let q = 0; q < this.n; q++) {
      const o = 3 * (this.rows[q] * nA + col);
      out[o] = this.acc[3 * q]; out[o + 1] = this.acc[3 * q + 1]; out[o + 2] = this.acc[3 * q + 2];
    }
  };

  // The exact Airy colour of one column on the wavelengths lam with weights w, complex arithmetic: any film (the
  // route "complex", and every route's texels integrated like the reference). E = exp(i phi), phi = 4 pi d q_b /
  // lambda, R = |a + b E|^2 / |1 + a b E|^2 per polarisation.
  function complexCoefficients(film, cosA, lam) {
    const co = new Float64Array(10 * lam.length);
    for (let l = 0; l < lam.length; l++) {
      const f = complexInterfaces(film.n_incident, filmIndex(film, lam[l]), film.k, film.n_substrate, cosA);
      co.set([FOUR_PI / lam[l] * f.qbr, FOUR_PI / lam[l] * f.qbi, ...f.as, ...f.bs, ...f.ap, ...f.bp], 10 * l);
    }
    return co;
  }

  function complexColumn(co, w, R, out, nA, col) {
    const acc = R.acc, n = co.length / 10;
    for (let l = 0; l < n; l++) {
      const o = 10 * l, kr = co[o], ki = co[o + 1];  // phi / d
      const sr = Math.exp(-R.step * ki) * Math.cos(R.step * kr), si = Math.exp(-R.step * ki) * Math.sin(R.step * kr);
      const asr = co[o + 2], asi = co[o + 3], bsr = co[o + 4], bsi = co[o + 5];
      const apr = co[o + 6], api = co[o + 7], bpr = co[o + 8], bpi = co[o + 9];
      const w0 = 0.5 * w[3 * l], w1 = 0.5 * w[3 * l + 1], w2 = 0.5 * w[3 * l + 2];
      let er = 0, ei = 0, prev = -2;
      for (let q = 0; q < R.n; q++) {
        const i = R.rows[q];
        if (i === prev + 1 && q > 0) {
          const t = er * sr - ei * si; ei = er * si + ei * sr; er = t;
        } else {
          const att = Math.exp(-R.d[i] * ki);
          er = att * Math.cos(R.d[i] * kr); ei = att * Math.sin(R.d[i] * kr);
        }
        prev = i;
        let v = 0;
        for (let p = 0; p < 2; p++) {
          const ar = p ? apr : asr, ai = p ? api : asi, br = p ? bpr : bsr, bi = p ? bpi : bsi;
          const ber = br * er - bi * ei, bei = br * ei + bi * er;  // b E
          const numr = ar + ber, numi = ai + bei;
          const denr = 1 + ar * ber - ai * bei, deni = ar * bei + ai * ber;  // 1 + a b E
          const dd = denr * denr + deni * deni;
          v += dd === 0 ? 1 : (numr * numr + numi * numi) / dd;
        }
        acc[3 * q] += v * w0; acc[3 * q + 1] += v * w1; acc[3 * q + 2] += v * w2;
      }
    }
    R.flush(out, nA, col);
  }

  // --- route "fourier" (rockdove.lut.bake._bake_fourier)
  function bakeFourier(T, film, cos, d, out) {
    const c = T.c, nA = cos.length, nT = d.length, tol = c.FOURIER_TOL;
    const nb = film.cauchy_a, na = film.n_incident, nc = film.n_substrate;
    const sampled = [];
    for (let j = 0; j < nA; j++) {
      const f = realInterfaces(na, nb, nc, cos[j]);
      const fs = airyFourier(f.as, f.bs), fp = airyFourier(f.ap, f.bp);
      const c0 = 0.5 * (fs[0] + fp[0]);
      const m = new Int32Array(nT);
      let mCol = 0;
      const fallback = [];
      for (let i = 0; i < nT; i++) {
        const opd = 2 * d[i] * f.qb;
        const mi = Math.max(termsNeeded(T, fs[1], fs[2], opd, tol), termsNeeded(T, fp[1], fp[2], opd, tol));
        if (mi > c.MAX_TERMS || !(opd > 0)) { fallback.push(i); continue; }
        m[i] = mi;
        mCol = Math.max(mCol, mi);
      }
      // coefficient of term m: (2 / P) sum_p c1_p rho_p^(m - 1), P = 2 polarisations
      const coef = new Float64Array(mCol);
      let ps = fs[1], pp = fp[1];
      for (let k = 0; k < mCol; k++) { coef[k] = ps + pp; ps *= fs[2]; pp *= fp[2]; }
      const acc = [0, 0, 0];
      for (let i = 0; i < nT; i++) {
        const opd = 2 * d[i] * f.qb;
        acc[0] = c0 * T.w0[0]; acc[1] = c0 * T.w0[1]; acc[2] = c0 * T.w0[2];
        for (let k = 0; k < mCol; k++) { addG(T, (k + 1) * opd, coef[k], acc); }
        const o = 3 * (i * nA + j);
        out[o] = acc[0]; out[o + 1] = acc[1]; out[o + 2] = acc[2];
      }
      if (fallback.length) { sampled.push([j, fallback]); }
    }
    for (const [j, rows] of sampled) {
      complexColumn(complexCoefficients(film, cos[j], T.ref.lam), T.ref.w, new Rows(d, rows), out, nA, j);
    }
  }

  // --- route "quadrature" (rockdove.lut.quadrature): the node plan of each column
  function columnPlan(T, film, cos, dMin, dMax) {
    const c = T.c, nA = cos.length, S = 17, half = 0.5 * (T.sHi - T.sLo);
    const ladder = T.ladder, top = ladder[ladder.length - 1];
    const plan = [];
    for (let j = 0; j < nA; j++) {
      let slope = 0, rho = 0, rhoMin = Infinity, qMin = Infinity, prev = 0;
      const cs = [], rs = [];
      for (let s = 0; s < S; s++) {
        const sig = T.sLo + (T.sHi - T.sLo) * s / (S - 1);
        const f = realInterfaces(film.n_incident, filmIndex(film, 1 / sig), film.n_substrate, cos[j]);
        const ph = FOUR_PI * dMax * sig * f.qb;
        if (s > 0) { slope = Math.max(slope, Math.abs(ph - prev)); }
        prev = ph;
        rho = Math.max(rho, Math.abs(f.as * f.bs), Math.abs(f.ap * f.bp));
        rhoMin = Math.min(rhoMin, -f.as * f.bs, -f.ap * f.bp);
        qMin = Math.min(qMin, f.qb);
        cs.push([airyFourier(f.as, f.bs), airyFourier(f.ap, f.bp)]);
        rs.push(f);
      }
      const dphi = slope / ((T.sHi - T.sLo) / (S - 1)) * half;
      const delta = -Math.log(rho);
      let nFull = (delta > 0 ? c.K_FULL * dphi / delta : Infinity) + c.N_MIN;
      if (cos[j] === 0) { nFull = 2; }
      let nSeries = Infinity, terms = 0;
      if (dMin > 0 && nFull > 2 * c.N_MIN && cos[j] > 0 && rhoMin >= 0) {
        const opdMin = 2 * dMin * qMin;
        let m = 0;
        for (let p = 0; p < 2; p++) {
          let c1 = 0, r = 0;
          for (const pair of cs) { c1 = Math.max(c1, Math.abs(pair[p][1])); r = Math.max(r, Math.abs(pair[p][2])); }
          m = Math.max(m, termsNeeded(T, c1, r, opdMin, c.SERIES_TOL));
        }
        terms = Math.max(m, 1);
        nSeries = c.K_SERIES * m * dphi + c.N_MIN;
      }
      const series = c.SERIES_COST * nSeries < nFull;
      const want = Math.min(series ? nSeries : nFull, c.MAX_NODES);
      const n = ladder.find((v) => v >= want);
      plan.push({ n: n === undefined || want > top ? 0 : n, terms: series ? terms : 0 });
    }
    return plan;
  }

  // A column's real interface coefficients at the nodes lam: per node phi / 2 per nm of film (2 pi q_b / lambda)
  // and a, b of s and p.
  function realCoefficients(film, cosA, lam) {
    const co = new Float64Array(5 * lam.length);
    for (let l = 0; l < lam.length; l++) {
      const f = realInterfaces(film.n_incident, filmIndex(film, lam[l]), film.n_substrate, cosA);
      co[5 * l] = TWO_PI * f.qb / lam[l];
      co[5 * l + 1] = f.as; co[5 * l + 2] = f.bs; co[5 * l + 3] = f.ap; co[5 * l + 4] = f.bp;
    }
    return co;
  }

  // The full Airy form at a column's nodes (rockdove.lut.quadrature._full_form): R = 1 - (1 - a^2)(1 - b^2) /
  // ((1 + p)^2 - 4 p sin^2(phi / 2)), p = a b, the 1 integrating to the nodes' white.
  function fullForm(co, nodes, R, out, nA, col) {
    const acc = R.acc, w = nodes.w, n = co.length / 5, d0 = R.d[R.rows[0]];
    for (let q = 0; q < R.n; q++) { acc.set(nodes.white, 3 * q); }
    for (let l = 0; l < n; l++) {
      const k = co[5 * l], as = co[5 * l + 1], bs = co[5 * l + 2], ap = co[5 * l + 3], bp = co[5 * l + 4];
      const ps = as * bs, pp = ap * bp, ds0 = (1 + ps) * (1 + ps), dp0 = (1 + pp) * (1 + pp);
      // (1 + p)^2 = 0: a b = -1 (cos theta = 0 between equal media), R = 1
      const ns = ds0 === 0 ? 0 : -0.5 * (1 - as * as) * (1 - bs * bs), ds = ds0 === 0 ? 1 : ds0;
      const np = dp0 === 0 ? 0 : -0.5 * (1 - ap * ap) * (1 - bp * bp), dp = dp0 === 0 ? 1 : dp0;
      const ss = -4 * ps, sp = -4 * pp;
      const rc = Math.cos(R.step * k), rs = Math.sin(R.step * k);
      const w0 = w[3 * l], w1 = w[3 * l + 1], w2 = w[3 * l + 2];
      let c = Math.cos(d0 * k), s = Math.sin(d0 * k);
      for (let q = 0; q < R.n; q++) {
        if (q > 0) { const t = c * rc - s * rs; s = c * rs + s * rc; c = t; }
        const s2 = s * s;
        const v = ns / (ss * s2 + ds) + np / (sp * s2 + dp);
        acc[3 * q] += v * w0; acc[3 * q + 1] += v * w1; acc[3 * q + 2] += v * w2;
      }
    }
    R.flush(out, nA, col);
  }

  // The truncated Poisson series of M terms at a column's nodes, summed in closed form in half-angle variables
  // (rockdove.lut.quadrature._series_form), s2 = sin^2(phi / 2):
  //   sum_{m=1..M} rho^(m-1) cos(m phi)
  //     = [((1 - rho) - 2 s2)(1 - rho^M cos(M phi)) + rho^M sin(M phi) sin(phi)] / ((1 - rho)^2 + 4 rho s2).
  function seriesForm(co, nodes, M, R, out, nA, col) {
    const acc = R.acc, w = nodes.w, n = co.length / 5, d0 = R.d[R.rows[0]];
    const cf = new Float64Array(12);
    for (let l = 0; l < n; l++) {
      const k = co[5 * l];
      for (let p = 0; p < 2; p++) {
        const [c0, c1, rho] = airyFourier(co[5 * l + 1 + 2 * p], co[5 * l + 2 + 2 * p]);
        cf[6 * p] = c0; cf[6 * p + 1] = 2 * c1; cf[6 * p + 2] = 1 - rho; cf[6 * p + 3] = 4 * rho;
        cf[6 * p + 4] = rho ** M; cf[6 * p + 5] = (1 - rho) * (1 - rho);
      }
      const rc = Math.cos(R.step * k), rs = Math.sin(R.step * k);  // phi / 2 per row
      const mc = Math.cos(2 * M * R.step * k), ms = Math.sin(2 * M * R.step * k);  // M phi per row
      const w0 = 0.5 * w[3 * l], w1 = 0.5 * w[3 * l + 1], w2 = 0.5 * w[3 * l + 2];
      let ch = Math.cos(d0 * k), sh = Math.sin(d0 * k), cm = Math.cos(2 * M * d0 * k), sm = Math.sin(2 * M * d0 * k);
      for (let q = 0; q < R.n; q++) {
        if (q > 0) {
          let t = ch * rc - sh * rs; sh = ch * rs + sh * rc; ch = t;
          t = cm * mc - sm * ms; sm = cm * ms + sm * mc; cm = t;
        }
        const s2 = sh * sh, sinPhi = 2 * sh * ch;
        let v = 0;
        for (let o = 0; o < 12; o += 6) {
          const num = (cf[o + 2] - 2 * s2) * (1 - cf[o + 4] * cm) + cf[o + 4] * sm * sinPhi;
          v += cf[o] + cf[o + 1] * num / (cf[o + 5] + cf[o + 3] * s2);
        }
        acc[3 * q] += v * w0; acc[3 * q + 1] += v * w1; acc[3 * q + 2] += v * w2;
      }
    }
    R.flush(out, nA, col);
  }

  // Chebyshev points of the second kind cos(pi j / (n - 1)) (rockdove.lut.weights.chebyshev).
  function chebyshev(n) {
    return Array.from({ length: n }, (_, j) => Math.cos(Math.PI * j / (n - 1)));
  }

  // Chebyshev angles across the columns cos theta >= ANGLE_PANEL_COS (rockdove.lut.quadrature.angle_panel_nodes).
  function panelNodes(T, film, cos, dMax) {
    const c = T.c;
    let lo = Infinity, hi = -Infinity, count = 0;
    for (const v of cos) { if (v >= c.ANGLE_PANEL_COS) { lo = Math.min(lo, v); hi = Math.max(hi, v); count++; } }
    if (!count || !(hi > lo)) { return null; }
    let psi = 0;
    const na2 = film.n_incident * film.n_incident;
    for (const sig of [T.sLo, T.sHi]) {
      const n = filmIndex(film, 1 / sig);
      const qHi = Math.sqrt(n * n - na2 * (1 - hi * hi)), qLo = Math.sqrt(n * n - na2 * (1 - lo * lo));
      psi = Math.max(psi, FOUR_PI * dMax * sig * Math.abs(qHi - qLo));
    }
    const nc = Math.ceil(c.K_ANGLE * psi + c.N_ANGLE_MIN);
    if (2 * nc > count) { return null; }
    return chebyshev(nc).reverse().map((y) => lo + (hi - lo) * 0.5 * (1 + y));
  }

  // Rows of the Lagrange basis on Chebyshev points `nodes` (second kind) at each x (barycentric formula).
  function barycentric(nodes, x) {
    const n = nodes.length;
    const v = Array.from({ length: n }, (_, j) => ((j % 2) ? -1 : 1) * ((j === 0 || j === n - 1) ? 0.5 : 1));
    return x.map((xi) => {
      const row = new Float64Array(n);
      const hit = nodes.indexOf(xi);
      if (hit >= 0) { row[hit] = 1; return row; }
      let s = 0;
      for (let k = 0; k < n; k++) { row[k] = v[k] / (xi - nodes[k]); s += row[k]; }
      for (let k = 0; k < n; k++) { row[k] /= s; }
      return row;
    });
  }

  // Bake the columns `cos` of one route with a column integrator, through the angle panel where it applies.
  function withPanel(T, film, cos, d, out, panelOk, columns) {
    const nA = cos.length, nT = d.length;
    const panel = panelOk ? panelNodes(T, film, cos, Math.max(...d)) : null;
    if (!panel) { columns(cos, out, nA); return; }
    const direct = [], inPanel = [];
    cos.forEach((v, j) => (v >= T.c.ANGLE_PANEL_COS ? inPanel : direct).push(j));
    const both = direct.map((j) => cos[j]).concat(panel);
    const sub = new Float64Array(nT * both.length * 3);
    columns(both, sub, both.length);
    const nb = both.length, nd = direct.length;
    for (let i = 0; i < nT; i++) {
      direct.forEach((j, k) => { for (let c = 0; c < 3; c++) { out[3 * (i * nA + j) + c] = sub[3 * (i * nb + k) + c]; } });
    }
    const basis = barycentric(panel, inPanel.map((j) => cos[j]));
    for (let i = 0; i < nT; i++) {
      const base = 3 * (i * nb + nd);
      inPanel.forEach((j, q) => {
        const row = basis[q];
        let r0 = 0, r1 = 0, r2 = 0;
        for (let k = 0; k < row.length; k++) {
          const b = row[k], o = base + 3 * k;
          r0 += b * sub[o]; r1 += b * sub[o + 1]; r2 += b * sub[o + 2];
        }
        const o = 3 * (i * nA + j);
        out[o] = r0; out[o + 1] = r1; out[o + 2] = r2;
      });
    }
  }

  // Consecutive rows in at most 8 groups, each planned on its own (the page's departure from rockdove.lut, for
  // speed): a group's node count follows its own thickest row's phase and thinnest row's damping, not the table's.
  function rowGroups(nT) {
    const size = Math.max(8, Math.ceil(nT / 8)), groups = [];
    for (let i = 0; i < nT; i += size) { groups.push(Array.from({ length: Math.min(size, nT - i) }, (_, k) => i + k)); }
    return groups;
  }

  function bakeQuadrature(T, film, cos, d, out) {
    withPanel(T, film, cos, d, out, true, (cs, dst, nA) => {
      const plans = [];
      for (const rows of rowGroups(d.length)) {
        const plan = columnPlan(T, film, cs, d[rows[0]], d[rows[rows.length - 1]]);
        plans.push([rows, plan]);
      }
      for (let j = 0; j < cs.length; j++) {
        const coefficients = new Map();  // node count -> this column's interface coefficients there
        for (const [rows, plan] of plans) {
          const { n, terms } = plan[j], R = new Rows(d, rows);
          if (n === 0) { complexColumn(complexCoefficients(film, cs[j], T.ref.lam), T.ref.w, R, dst, nA, j); continue; }
          if (!coefficients.has(n)) { coefficients.set(n, realCoefficients(film, cs[j], T.nodes[n].lam)); }
          if (terms > 0) { seriesForm(coefficients.get(n), T.nodes[n], terms, R, dst, nA, j); }
          else { fullForm(coefficients.get(n), T.nodes[n], R, dst, nA, j); }
        }
      }
    });
  }

  // --- route "complex": node count from the resonances' damping, the 0.1 nm grid where the ladder ends
  function complexPlan(T, film, cosA, dMin, dMax) {
    const c = T.c, S = 17, half = 0.5 * (T.sHi - T.sLo), na = film.n_incident;
    let slope = 0, prev = 0, rho = 0, att = Infinity, q2Min = Infinity, q2Max = -Infinity;
    for (let s = 0; s < S; s++) {
      const sig = T.sLo + (T.sHi - T.sLo) * s / (S - 1), nr = filmIndex(film, 1 / sig);
      const f = complexInterfaces(na, nr, film.k, film.n_substrate, cosA);
      const ph = FOUR_PI * dMax * sig * f.qbr;
      if (s > 0) { slope = Math.max(slope, Math.abs(ph - prev)); }
      prev = ph;
      rho = Math.max(rho, Math.hypot(...f.as) * Math.hypot(...f.bs), Math.hypot(...f.ap) * Math.hypot(...f.bp));
      att = Math.min(att, FOUR_PI * dMin * sig * f.qbi);  // Im phi: one round trip's damping
      const q2 = nr * nr - film.k * film.k - na * na * (1 - cosA * cosA);
      q2Min = Math.min(q2Min, q2); q2Max = Math.max(q2Max, q2);
    }
    // a transparent film whose critical angle moves through this column over the spectrum: R(sigma) has a branch
    // point on (or near) the interval, so no polynomial converges fast there
    if (film.k === 0 && q2Max > q2Min && q2Min < 4 * (q2Max - q2Min) && q2Max > -4 * (q2Max - q2Min)) { return 0; }
    const dphi = slope / ((T.sHi - T.sLo) / (S - 1)) * half;
    const delta = -Math.log(rho) + att;
    const want = (delta > 0 ? c.K_FULL * dphi / delta : Infinity) + c.N_MIN;
    const n = T.ladder.find((v) => v >= want);
    return n === undefined ? 0 : n;
  }

  function bakeComplex(T, film, cos, d, out) {
    const na = film.n_incident;
    const panelOk = film.n_substrate >= na && filmIndex(film, 780) >= na;
    const air = film.cauchy_a === na && film.cauchy_b_nm2 === 0 && film.k === 0 && film.n_substrate === na;
    withPanel(T, film, cos, d, out, panelOk, (cs, dst, nA) => {
      for (let j = 0; j < cs.length; j++) {
        if (cs[j] === 0 && !air) {  // grazing: R = 1 (a = -1) for any film
          for (let i = 0; i < d.length; i++) { dst.set(T.ref.white, 3 * (i * nA + j)); }
          continue;
        }
        const coefficients = new Map();  // node count -> this column's interface coefficients there
        for (const rows of rowGroups(d.length)) {
          const n = complexPlan(T, film, cs[j], d[rows[0]], d[rows[rows.length - 1]]);
          const nodes = n ? T.nodes[n] : T.ref;
          if (!coefficients.has(n)) { coefficients.set(n, complexCoefficients(film, cs[j], nodes.lam)); }
          complexColumn(coefficients.get(n), nodes.w, new Rows(d, rows), dst, nA, j);
        }
      }
    });
  }

  const ROUTES = { fourier: bakeFourier, quadrature: bakeQuadrature, complex: bakeComplex };

  /**
   * Bake a LUT. film: {cauchy_a, cauchy_b_nm2, k, n_incident, n_substrate} (checked by the caller); grid:
   * {angles, thicknesses, thicknessRangeNm: [lo, hi], angleWarpGamma} (one row at the mid-point when lo == hi).
   * Returns {rgb: Float32Array(thicknesses * angles * 3), angles, thicknesses, thicknessRangeNm, angleWarpGamma,
   * method, ms}.
   */
  function bake(tables, film, grid) {
    const t0 = (typeof performance !== "undefined" ? performance : Date).now();
    let [lo, hi] = grid.thicknessRangeNm;
    let nT = grid.thicknesses;
    if (nT === 1 || lo === hi) { lo = hi = 0.5 * (lo + hi); nT = 1; }
    const nA = grid.angles, gamma = grid.angleWarpGamma;
    const cos = Array.from({ length: nA }, (_, j) => (j / (nA - 1)) ** gamma);
    const d = Array.from({ length: nT }, (_, i) => (nT > 1 ? lo + (hi - lo) * i / (nT - 1) : lo));
    const out = new Float64Array(nT * nA * 3);
    const method = route(film);
    ROUTES[method](tables, film, cos, d, out);
    const rgb = new Float32Array(out);
    const ms = (typeof performance !== "undefined" ? performance : Date).now() - t0;
    return { rgb, angles: nA, thicknesses: nT, thicknessRangeNm: [lo, hi], angleWarpGamma: gamma, method, ms };
  }

  const api = { Tables, bake, route };
  root.RockdoveFilmBake = api;
})(typeof window !== "undefined" ? window : globalThis);
