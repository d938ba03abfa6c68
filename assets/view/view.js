// volmap view: the page's script. Written for volmap, no library. The data (the element
// #volmap-data) hold each part's values at the nodes shown, point p = i + nx·(j + ny·k), then
// the six channels OE.X OE.Y OE.Z (rad) VE.X VE.Y VE.Z (mm), f32 little endian in base64.
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("volmap-data").textContent);

  // Browsers are little endian: the bytes are the Float32Array's as they stand.
  function decode(b64) {
    const text = atob(b64);
    const bytes = new Uint8Array(text.length);
    for (let n = 0; n < text.length; n++) bytes[n] = text.charCodeAt(n);
    return new Float32Array(bytes.buffer);
  }

  // Each pose's values are decoded when it is first shown.
  const parts = data.parts.map(function (p) {
    const part = Object.assign({}, p);
    let v = null, u = null;
    Object.defineProperty(part, "v", { get: () => v || (v = decode(p.values)) });
    Object.defineProperty(part, "u", {
      get: () => (p.uncertainty ? u || (u = decode(p.uncertainty)) : null),
    });
    return part;
  });

  // What the colours can show: a magnitude (sequential colours from 0) or a signed component
  // (diverging colours about 0), in µm or µrad; `u` reads the uncertainties.
  const magnitude = (a, b, c) => Math.hypot(a, b, c);
  const QUANTITIES = [
    { key: "VE", label: "|VE|", unit: "µm", signed: false, of: (v, o) => 1e3 * magnitude(v[o + 3], v[o + 4], v[o + 5]) },
    { key: "VE.X", label: "VE.X", unit: "µm", signed: true, of: (v, o) => 1e3 * v[o + 3] },
    { key: "VE.Y", label: "VE.Y", unit: "µm", signed: true, of: (v, o) => 1e3 * v[o + 4] },
    { key: "VE.Z", label: "VE.Z", unit: "µm", signed: true, of: (v, o) => 1e3 * v[o + 5] },
    { key: "OE", label: "|OE|", unit: "µrad", signed: false, of: (v, o) => 1e6 * magnitude(v[o], v[o + 1], v[o + 2]) },
    { key: "OE.X", label: "OE.X", unit: "µrad", signed: true, of: (v, o) => 1e6 * v[o] },
    { key: "OE.Y", label: "OE.Y", unit: "µrad", signed: true, of: (v, o) => 1e6 * v[o + 1] },
    { key: "OE.Z", label: "OE.Z", unit: "µrad", signed: true, of: (v, o) => 1e6 * v[o + 2] },
    { key: "u", label: "u(VE)", unit: "µm", signed: false, u: true, of: (v, o) => 1e3 * magnitude(v[o + 3], v[o + 4], v[o + 5]) },
    { key: "u(VE.X)", label: "u(VE.X)", unit: "µm", signed: false, u: true, of: (v, o) => 1e3 * v[o + 3] },
    { key: "u(VE.Y)", label: "u(VE.Y)", unit: "µm", signed: false, u: true, of: (v, o) => 1e3 * v[o + 4] },
    { key: "u(VE.Z)", label: "u(VE.Z)", unit: "µm", signed: false, u: true, of: (v, o) => 1e3 * v[o + 5] },
  ];

  const state = {
    part: 0,
    quantity: QUANTITIES[0],
    at: [0, 0, 0],
    yaw: -0.5,
    pitch: -0.45,
    zoom: 1,
    scale: 1,
    hover: null,
  };

  const $ = (id) => document.getElementById(id);
  const part = () => parts[state.part];
  const index = (p, i, j, k) => i + p.dims[0] * (j + p.dims[1] * k);
  const fixed = (x, digits) => (Object.is(x, -0) ? 0 : x).toFixed(digits);

  function quantityValue(p, q, n) {
    const values = q.u ? p.u : p.v;
    return q.of(values, 6 * n);
  }

  // The range of a quantity over every node shown of a part: [0, max] or [−m, m].
  const ranges = new Map();
  function range(p, q) {
    const key = state.part + " " + q.key;
    if (!ranges.has(key)) {
      let lo = Infinity, hi = -Infinity;
      const count = p.dims[0] * p.dims[1] * p.dims[2];
      for (let n = 0; n < count; n++) {
        const x = quantityValue(p, q, n);
        if (x < lo) lo = x;
        if (x > hi) hi = x;
      }
      if (q.signed) {
        const m = Math.max(Math.abs(lo), Math.abs(hi)) || 1e-12;
        ranges.set(key, [-m, m]);
      } else {
        ranges.set(key, [0, hi > 0 ? hi : 1e-12]);
      }
    }
    return ranges.get(key);
  }

  // Colours: viridis-like stops for magnitudes, blue–white–red for signed values.
  const SEQUENTIAL = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const DIVERGING = [[33, 102, 172], [146, 197, 222], [247, 247, 247], [244, 165, 130], [178, 24, 43]];
  function colour(t, signed) {
    const stops = signed ? DIVERGING : SEQUENTIAL;
    const x = Math.min(1, Math.max(0, isFinite(t) ? t : 0)) * (stops.length - 1);
    const n = Math.min(stops.length - 2, Math.floor(x));
    const f = x - n;
    return stops[n].map((c, m) => Math.round(c + f * (stops[n + 1][m] - c)));
  }
  function colourOf(p, q, n) {
    const [lo, hi] = range(p, q);
    return colour((quantityValue(p, q, n) - lo) / (hi - lo), q.signed);
  }

  // The three sections: the plane each shows, its horizontal and vertical axes.
  const SECTIONS = [
    { id: "x", axis: 0, across: [1, 2], names: ["Y", "Z"] },
    { id: "y", axis: 1, across: [0, 2], names: ["X", "Z"] },
    { id: "z", axis: 2, across: [0, 1], names: ["X", "Y"] },
  ];
  const AXES = ["X", "Y", "Z"];
  const MARGIN = { left: 56, right: 24, top: 10, bottom: 30 };

  // Cell edges of nodes at `coords`: half-way between neighbours, the ends at the end nodes.
  function edges(coords) {
    if (coords.length === 1) return [coords[0] - 0.5, coords[0] + 0.5];
    const out = [coords[0]];
    for (let n = 0; n + 1 < coords.length; n++) out.push(0.5 * (coords[n] + coords[n + 1]));
    out.push(coords[coords.length - 1]);
    return out;
  }

  // How a section maps mm to pixels: equal scales, the plane fitted into the canvas.
  function frame(canvas, p, s) {
    const [a, b] = s.across;
    const ea = edges(p.coords_mm[a]), eb = edges(p.coords_mm[b]);
    const spanA = Math.max(ea[ea.length - 1] - ea[0], 1e-9);
    const spanB = Math.max(eb[eb.length - 1] - eb[0], 1e-9);
    const w = canvas.width - MARGIN.left - MARGIN.right;
    const h = canvas.height - MARGIN.top - MARGIN.bottom;
    const k = Math.min(w / spanA, h / spanB);
    const x0 = MARGIN.left + 0.5 * (w - k * spanA);
    const y0 = MARGIN.top + 0.5 * (h + k * spanB);
    return {
      ea, eb, k,
      x: (mm) => x0 + k * (mm - ea[0]),
      y: (mm) => y0 - k * (mm - eb[0]),
      mmA: (px) => ea[0] + (px - x0) / k,
      mmB: (py) => eb[0] + (y0 - py) / k,
    };
  }

  function nodeAt(p, s, n, i) {
    const at = state.at.slice();
    at[s.axis] = state.at[s.axis];
    at[s.across[0]] = n;
    at[s.across[1]] = i;
    return at;
  }

  function drawSection(s) {
    const canvas = $("section-" + s.id);
    const g = canvas.getContext("2d");
    const p = part(), q = state.quantity;
    g.fillStyle = "#fff";
    g.fillRect(0, 0, canvas.width, canvas.height);
    const f = frame(canvas, p, s);
    const [a, b] = s.across;
    for (let m = 0; m < p.dims[b]; m++) {
      for (let n = 0; n < p.dims[a]; n++) {
        const [i, j, k] = nodeAt(p, s, n, m);
        const c = colourOf(p, q, index(p, i, j, k));
        g.fillStyle = "rgb(" + c[0] + "," + c[1] + "," + c[2] + ")";
        const x1 = f.x(f.ea[n]), x2 = f.x(f.ea[n + 1]);
        const y1 = f.y(f.eb[m + 1]), y2 = f.y(f.eb[m]);
        g.fillRect(x1, y1, Math.max(1, x2 - x1 + 0.5), Math.max(1, y2 - y1 + 0.5));
      }
    }
    // The other two sections' planes.
    g.strokeStyle = "rgba(0,0,0,0.45)";
    g.setLineDash([4, 3]);
    const xa = f.x(p.coords_mm[a][state.at[a]]), yb = f.y(p.coords_mm[b][state.at[b]]);
    g.beginPath();
    g.moveTo(xa, f.y(f.eb[0])); g.lineTo(xa, f.y(f.eb[f.eb.length - 1]));
    g.moveTo(f.x(f.ea[0]), yb); g.lineTo(f.x(f.ea[f.ea.length - 1]), yb);
    g.stroke();
    g.setLineDash([]);
    drawFeatures(g, f, s);
    // Axes: the ends of each, mm.
    g.fillStyle = "#222";
    g.font = "11px sans-serif";
    const ca = p.coords_mm[a], cb = p.coords_mm[b];
    g.textAlign = "center";
    g.fillText(fixed(ca[0], 1), f.x(ca[0]), canvas.height - 16);
    g.fillText(fixed(ca[ca.length - 1], 1), f.x(ca[ca.length - 1]), canvas.height - 16);
    g.fillText(s.names[0] + " (mm)", 0.5 * (f.x(ca[0]) + f.x(ca[ca.length - 1])), canvas.height - 3);
    g.textAlign = "right";
    g.fillText(fixed(cb[0], 1), MARGIN.left - 4, f.y(cb[0]) + 4);
    g.fillText(fixed(cb[cb.length - 1], 1), MARGIN.left - 4, f.y(cb[cb.length - 1]) + 10);
    g.save();
    g.translate(12, 0.5 * (f.y(cb[0]) + f.y(cb[cb.length - 1])));
    g.rotate(-Math.PI / 2);
    g.textAlign = "center";
    g.fillText(s.names[1] + " (mm)", 0, 0);
    g.restore();
    const c = p.coords_mm[s.axis][state.at[s.axis]];
    $("caption-" + s.id).textContent = "section " + AXES[s.axis] + " = " + fixed(c, 3) +
      " mm (node " + (state.at[s.axis] + 1) + " of " + p.dims[s.axis] + ")";
  }

  // The part's features: the cutter's positions as dots, each feature's worst point ringed in
  // the colour of its decision, named.
  function drawFeatures(g, f, s) {
    if (!data.features.length) return;
    const [a, b] = s.across;
    g.fillStyle = "rgba(0,0,0,0.35)";
    for (const pt of data.cutter_points_mm) g.fillRect(f.x(pt[a]) - 0.5, f.y(pt[b]) - 0.5, 1.5, 1.5);
    g.font = "11px sans-serif";
    g.textAlign = "left";
    for (const feature of data.features) {
      const w = feature.worst_point_mm;
      g.strokeStyle = feature.conformance === "does not conform" ? "#b00020"
        : feature.conformance === "undecided" ? "#c26a00" : "#0a7d2c";
      g.lineWidth = 2;
      g.beginPath();
      g.arc(f.x(w[a]), f.y(w[b]), 5, 0, 2 * Math.PI);
      g.stroke();
      g.lineWidth = 1;
      g.fillStyle = "#000";
      g.fillText(feature.name, f.x(w[a]) + 7, f.y(w[b]) - 6);
    }
  }

  function drawColourBar() {
    const canvas = $("colorbar");
    const g = canvas.getContext("2d");
    const p = part(), q = state.quantity;
    const [lo, hi] = range(p, q);
    g.fillStyle = "#fff";
    g.fillRect(0, 0, canvas.width, canvas.height);
    const x0 = 20, w = canvas.width - 40;
    for (let n = 0; n < w; n++) {
      const c = colour(n / (w - 1), q.signed);
      g.fillStyle = "rgb(" + c[0] + "," + c[1] + "," + c[2] + ")";
      g.fillRect(x0 + n, 8, 1, 24);
    }
    g.fillStyle = "#222";
    g.font = "11px sans-serif";
    g.textAlign = "center";
    for (let n = 0; n <= 4; n++) {
      const v = lo + (hi - lo) * n / 4;
      g.fillText(v.toPrecision(3), x0 + w * n / 4, 46);
    }
    g.fillText(q.label + " (" + q.unit + ")", canvas.width / 2, 64);
  }

  // The deformed grid: the ideal nodes (grey) and the real tool tips, the errors times the
  // scale, coloured by the quantity; at most 9 nodes along an axis.
  function draw3d() {
    const canvas = $("deformed");
    const g = canvas.getContext("2d");
    const p = part(), q = state.quantity;
    g.fillStyle = "#fff";
    g.fillRect(0, 0, canvas.width, canvas.height);
    const pick = (n) => {
      const m = Math.min(n, 9);
      if (m <= 1) return [0];
      return Array.from({ length: m }, (_, t) => Math.round(t * (n - 1) / (m - 1)));
    };
    const picks = [0, 1, 2].map((d) => pick(p.dims[d]));
    const lo = [0, 1, 2].map((d) => p.coords_mm[d][0]);
    const hi = [0, 1, 2].map((d) => p.coords_mm[d][p.dims[d] - 1]);
    const centre = [0, 1, 2].map((d) => 0.5 * (lo[d] + hi[d]));
    const diagonal = Math.max(Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]), 1e-9);
    const k = state.zoom * Math.min(canvas.width, canvas.height) / (1.25 * diagonal);
    const [cy, sy, cp, sp] = [Math.cos(state.yaw), Math.sin(state.yaw), Math.cos(state.pitch), Math.sin(state.pitch)];
    const project = (x, y, z) => {
      const dx = x - centre[0], dy = y - centre[1], dz = z - centre[2];
      const rx = cy * dx - sy * dy, ry = sy * dx + cy * dy;
      const depth = cp * ry + sp * dz;
      const up = -sp * ry + cp * dz;
      return [canvas.width / 2 + k * rx, canvas.height / 2 - k * up, depth];
    };
    const tip = (i, j, k2, real) => {
      const n = index(p, i, j, k2);
      const s = real ? state.scale : 0;
      return project(
        p.coords_mm[0][i] + s * p.v[6 * n + 3],
        p.coords_mm[1][j] + s * p.v[6 * n + 4],
        p.coords_mm[2][k2] + s * p.v[6 * n + 5]);
    };
    for (const real of [false, true]) {
      for (const i of picks[0]) for (const j of picks[1]) for (const k2 of picks[2]) {
        const here = tip(i, j, k2, real);
        const c = colourOf(p, q, index(p, i, j, k2));
        g.strokeStyle = real ? "rgb(" + c[0] + "," + c[1] + "," + c[2] + ")" : "rgba(0,0,0,0.18)";
        g.lineWidth = real ? 1.6 : 1;
        const next = [
          [picks[0][picks[0].indexOf(i) + 1], j, k2],
          [i, picks[1][picks[1].indexOf(j) + 1], k2],
          [i, j, picks[2][picks[2].indexOf(k2) + 1]],
        ];
        for (const [a, b, c2] of next) {
          if (a === undefined || b === undefined || c2 === undefined) continue;
          const there = tip(a, b, c2, real);
          g.beginPath();
          g.moveTo(here[0], here[1]);
          g.lineTo(there[0], there[1]);
          g.stroke();
        }
      }
    }
    // Which way X, Y and Z point.
    const o = [44, canvas.height - 40];
    g.font = "12px sans-serif";
    g.fillStyle = "#222";
    AXES.forEach((name, d) => {
      const e = [0, 0, 0];
      e[d] = 1;
      const rx = cy * e[0] - sy * e[1], ry = sy * e[0] + cy * e[1];
      const up = -sp * ry + cp * e[2];
      g.strokeStyle = "#222";
      g.beginPath();
      g.moveTo(o[0], o[1]);
      g.lineTo(o[0] + 26 * rx, o[1] - 26 * up);
      g.stroke();
      g.fillText(name, o[0] + 32 * rx - 4, o[1] - 32 * up + 4);
    });
    $("caption-3d").textContent = "deformed grid: ideal nodes grey, real tool tips with the errors × " +
      String(state.scale) + ", coloured by " + q.label;
  }

  function readout(at) {
    const p = part();
    const n = index(p, at[0], at[1], at[2]);
    const v = p.v, o = 6 * n;
    const lines = [
      "commanded X " + fixed(p.coords_mm[0][at[0]], 4) + "  Y " + fixed(p.coords_mm[1][at[1]], 4) +
        "  Z " + fixed(p.coords_mm[2][at[2]], 4) + " mm",
      "VE  X " + fixed(1e3 * v[o + 3], 4) + "  Y " + fixed(1e3 * v[o + 4], 4) + "  Z " + fixed(1e3 * v[o + 5], 4) +
        "  |VE| " + fixed(1e3 * magnitude(v[o + 3], v[o + 4], v[o + 5]), 4) + " µm",
      "OE  X " + fixed(1e6 * v[o], 3) + "  Y " + fixed(1e6 * v[o + 1], 3) + "  Z " + fixed(1e6 * v[o + 2], 3) + " µrad",
    ];
    if (p.u) {
      lines.push("u(VE)  X " + fixed(1e3 * p.u[o + 3], 4) + "  Y " + fixed(1e3 * p.u[o + 4], 4) +
        "  Z " + fixed(1e3 * p.u[o + 5], 4) + " µm");
    }
    $("readout").textContent = lines.join("\n");
  }

  function nearest(coords, mm) {
    let best = 0;
    for (let n = 1; n < coords.length; n++) {
      if (Math.abs(coords[n] - mm) < Math.abs(coords[best] - mm)) best = n;
    }
    return best;
  }

  function drawAll() {
    SECTIONS.forEach(drawSection);
    drawColourBar();
    draw3d();
    if (state.hover) readout(state.hover);
  }

  function niceScale(x) {
    if (!(x > 0) || !isFinite(x)) return 1;
    const e = Math.pow(10, Math.floor(Math.log10(x)));
    const m = x / e;
    return (m >= 5 ? 5 : m >= 2 ? 2 : 1) * e;
  }

  function setPart(n) {
    state.part = n;
    const p = part();
    SECTIONS.forEach((s) => {
      const slider = $("slider-" + s.id);
      slider.max = String(p.dims[s.axis] - 1);
      state.at[s.axis] = Math.floor((p.dims[s.axis] - 1) / 2);
      slider.value = String(state.at[s.axis]);
    });
    const extent = Math.max(...[0, 1, 2].map((d) => p.coords_mm[d][p.dims[d] - 1] - p.coords_mm[d][0]));
    state.scale = niceScale(0.08 * extent / Math.max(p.largest_ve_mm, 1e-12));
    $("scale").value = String(state.scale);
    const quantities = QUANTITIES.filter((q) => !q.u || p.u);
    const select = $("quantity");
    select.innerHTML = "";
    for (const q of quantities) select.add(new Option(q.label, q.key));
    if (!quantities.includes(state.quantity)) state.quantity = quantities[0];
    select.value = state.quantity.key;
    facts();
    drawAll();
  }

  function text(tag, content, className) {
    const e = document.createElement(tag);
    e.textContent = content;
    if (className) e.className = className;
    return e;
  }

  function facts() {
    const p = part();
    $("title").textContent = data.machine + " (" + data.chain + ")";
    const box = $("facts");
    box.innerHTML = "";
    const fact = (name, value) => {
      const line = document.createElement("div");
      line.appendChild(text("b", name + ": "));
      line.appendChild(document.createTextNode(value));
      box.appendChild(line);
    };
    fact("values", data.source + ", computed on " + data.device);
    if (p.name) fact("pose", p.name);
    fact("inputs", p.inputs);
    const w = p.largest_at_mm;
    fact("largest error", "|VE| " + fixed(1e3 * p.largest_ve_mm, 3) + " µm at X " + fixed(w[0], 3) +
      " Y " + fixed(w[1], 3) + " Z " + fixed(w[2], 3) + " mm; |OE| " + fixed(1e6 * p.largest_oe_rad, 3) +
      " µrad (over every node of the field)");
    if (p.uncertainty_method) fact("uncertainty", p.uncertainty_method);
    const shown = p.dims.join("×"), full = p.full_dims.join("×");
    $("note").textContent = shown === full
      ? "every node of the " + full + " grid shown"
      : "shown at " + shown + " of the field's " + full + " grid nodes (evenly spaced nodes, the ends included)";
  }

  function featureTable() {
    const box = $("features");
    if (!data.features.length) return;
    box.appendChild(text("h2", "Features of " + data.part_file));
    const table = document.createElement("table");
    const head = document.createElement("tr");
    for (const h of ["feature", "kind", "error (µm)", "U, k = 2 (µm)", "tolerance (µm)", "rating", "ISO 14253-1"]) {
      head.appendChild(text("th", h));
    }
    table.appendChild(head);
    for (const f of data.features) {
      const row = document.createElement("tr");
      row.appendChild(text("td", f.name));
      row.appendChild(text("td", f.kind));
      row.appendChild(text("td", fixed(1e3 * f.error_mm, 3)));
      row.appendChild(text("td", fixed(1e3 * f.u_expanded_mm, 3)));
      row.appendChild(text("td", fixed(1e3 * f.tolerance_mm, 3)));
      row.appendChild(text("td", f.verdict, f.verdict));
      row.appendChild(text("td", f.conformance, f.conformance.replace(/ /g, "-")));
      table.appendChild(row);
    }
    box.appendChild(table);
  }

  // Controls.
  const partSelect = $("part");
  parts.forEach((p, n) => partSelect.add(new Option(p.name || "(the one pose)", String(n))));
  partSelect.disabled = parts.length < 2;
  partSelect.addEventListener("change", () => setPart(Number(partSelect.value)));
  $("quantity").addEventListener("change", (e) => {
    state.quantity = QUANTITIES.find((q) => q.key === e.target.value);
    drawAll();
  });
  SECTIONS.forEach((s) => {
    $("slider-" + s.id).addEventListener("input", (e) => {
      state.at[s.axis] = Number(e.target.value);
      drawAll();
    });
    const canvas = $("section-" + s.id);
    canvas.addEventListener("mousemove", (e) => {
      const p = part();
      const r = canvas.getBoundingClientRect();
      const f = frame(canvas, p, s);
      const [a, b] = s.across;
      const at = state.at.slice();
      at[a] = nearest(p.coords_mm[a], f.mmA((e.clientX - r.left) * canvas.width / r.width));
      at[b] = nearest(p.coords_mm[b], f.mmB((e.clientY - r.top) * canvas.height / r.height));
      state.hover = at;
      readout(at);
    });
  });
  $("scale").addEventListener("input", (e) => {
    const s = Number(e.target.value);
    if (isFinite(s) && s >= 0) { state.scale = s; draw3d(); }
  });
  const deformed = $("deformed");
  let drag = null;
  deformed.addEventListener("mousedown", (e) => { drag = [e.clientX, e.clientY]; });
  window.addEventListener("mouseup", () => { drag = null; });
  window.addEventListener("mousemove", (e) => {
    if (!drag) return;
    state.yaw += 0.01 * (e.clientX - drag[0]);
    state.pitch = Math.max(-1.57, Math.min(1.57, state.pitch + 0.01 * (e.clientY - drag[1])));
    drag = [e.clientX, e.clientY];
    draw3d();
  });
  deformed.addEventListener("wheel", (e) => {
    e.preventDefault();
    state.zoom *= Math.exp(-0.001 * e.deltaY);
    draw3d();
  }, { passive: false });
  $("footer").textContent = "written by " + data.written_by + "; every value and script is inside this file";

  featureTable();
  setPart(0);

  // What a test reads: the values at a node, the pictures' signatures, the controls.
  function signature(id) {
    const canvas = $(id);
    const pixels = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
    let drawn = 0, hash = 2166136261;
    for (let n = 0; n < pixels.length; n += 4) {
      if (pixels[n] !== 255 || pixels[n + 1] !== 255 || pixels[n + 2] !== 255) drawn++;
      hash = Math.imul(hash ^ pixels[n] ^ (pixels[n + 1] << 8) ^ (pixels[n + 2] << 16), 16777619) >>> 0;
    }
    return { drawn: drawn, hash: hash };
  }
  function value(n, i, j, k) {
    const p = parts[n];
    const o = 6 * index(p, i, j, k);
    const pick = (arr, from) => arr ? Array.from(arr.slice(o + from, o + from + 3)) : null;
    return {
      x_mm: p.coords_mm[0][i], y_mm: p.coords_mm[1][j], z_mm: p.coords_mm[2][k],
      ve_mm: pick(p.v, 3), oe_rad: pick(p.v, 0), u_ve_mm: pick(p.u, 3),
    };
  }
  window.volmapView = {
    parts: parts.map((p) => ({ name: p.name, dims: p.dims, node_indices: p.node_indices })),
    value: value,
    signature: signature,
    setPart: (n) => { partSelect.value = String(n); setPart(n); },
    setQuantity: (key) => {
      const select = $("quantity");
      select.value = key;
      select.dispatchEvent(new Event("change"));
    },
    moveSlider: (axis, n) => {
      const slider = $("slider-" + axis);
      slider.value = String(n);
      slider.dispatchEvent(new Event("input"));
    },
  };

  // `#selftest` (with `=i,j,k;i,j,k…` nodes of part 0): the page checks itself and writes what it
  // found into #volmap-selftest, for a headless browser to read.
  if (location.hash.startsWith("#selftest")) {
    const nodes = (location.hash.split("=")[1] || "").split(";").filter((t) => t)
      .map((t) => t.split(",").map(Number));
    const canvases = {};
    for (const id of ["section-x", "section-y", "section-z", "colorbar", "deformed"]) canvases[id] = signature(id);
    const p0 = parts[0];
    const before = signature("section-x");
    const to = state.at[0] === 0 ? p0.dims[0] - 1 : 0;
    window.volmapView.moveSlider("x", to);
    const after = signature("section-x");
    const quantities = Array.from($("quantity").options).map((o) => o.value);
    let byQuantity = null;
    if (quantities.includes("VE.X")) {
      window.volmapView.setQuantity("VE.X");
      byQuantity = signature("section-z");
      window.volmapView.setQuantity("VE");
    }
    $("volmap-selftest").textContent = JSON.stringify({
      errors: window.volmapErrors,
      canvases: canvases,
      slider: { to: to, before: before, after: after },
      signed_section_z: byQuantity,
      quantities: quantities,
      parts: window.volmapView.parts,
      note: $("note").textContent,
      facts: $("facts").textContent,
      features: $("features").textContent,
      values: nodes.map((n) => value(0, n[0], n[1], n[2])),
    });
  }
})();
