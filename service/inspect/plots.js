// The figures of dynamics.plot.trajectory, drawn on canvases: q, v and tau against t, one line per coordinate,
// a legend up to ten coordinates, and the report's one-line verdict (dynamics.plot.report_title) as the title.
"use strict";
const Plots = (() => {
  const MAX_LEGEND = 10;
  const UNITS = {q: "position (rad, m)", v: "velocity (rad/s, m/s)", tau: "torque (N m, N)"};
  const COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                  "#bcbd22", "#17becf"];

  function exp1(x) {  // Python's f"{x:.1e}": at least two exponent digits
    const [m, e] = x.toExponential(1).split("e");
    const n = Math.abs(Number(e));
    return `${m}e${Number(e) < 0 ? "-" : "+"}${n < 10 ? "0" : ""}${n}`;
  }

  function reportTitle(report) {  // dynamics.plot.report_title
    const parts = [String(report.integrator || ""), `status ${report.status ?? "?"}`];
    for (const [key, label] of [["error_estimate", "error"], ["energy_drift", "energy drift"]]) {
      const x = report[key];
      if (typeof x === "number" && isFinite(x)) parts.push(`${label} ${exp1(x)}`);
    }
    if ("steps" in report) parts.push(`${report.steps} steps`);
    if ("wall_time_s" in report) parts.push(`${Math.round(report.wall_time_s * 1e3)} ms`);
    return parts.filter(Boolean).join(", ");
  }

  function range(x) {
    let lo = Infinity, hi = -Infinity;
    for (const row of x) for (const y of row) if (isFinite(y)) { lo = Math.min(lo, y); hi = Math.max(hi, y); }
    if (!isFinite(lo)) return [-1, 1];
    if (hi - lo < 1e-12) { lo -= 1; hi += 1; }
    const pad = 0.05 * (hi - lo);
    return [lo - pad, hi + pad];
  }

  function panel(canvas, t, x, name, labels, cursor) {
    const dpr = window.devicePixelRatio || 1, w = canvas.clientWidth || 400, h = canvas.clientHeight || 150;
    canvas.width = w * dpr; canvas.height = h * dpr;
    const g = canvas.getContext("2d");
    g.scale(dpr, dpr);
    g.clearRect(0, 0, w, h);
    const L = 48, R = 6, T = 6, B = 18, t0 = t[0], t1 = t[t.length - 1] > t0 ? t[t.length - 1] : t0 + 1;
    const [lo, hi] = range(x);
    const X = (s) => L + (s - t0) / (t1 - t0) * (w - L - R), Y = (y) => T + (hi - y) / (hi - lo) * (h - T - B);
    g.strokeStyle = "#ddd"; g.fillStyle = "#555"; g.font = "10px sans-serif"; g.lineWidth = 1;
    for (let k = 0; k <= 4; k++) {
      const y = lo + (hi - lo) * k / 4;
      g.beginPath(); g.moveTo(L, Y(y)); g.lineTo(w - R, Y(y)); g.stroke();
      g.fillText(y.toPrecision(3), 2, Y(y) + 3);
      const s = t0 + (t1 - t0) * k / 4;
      g.fillText(s.toPrecision(3), X(s) - 8, h - 5);
    }
    g.save(); g.translate(10, T + 2); g.fillText(UNITS[name], L, 8); g.restore();
    const n = x.length ? x[0].length : 0;
    for (let k = 0; k < n; k++) {
      g.strokeStyle = COLORS[k % COLORS.length]; g.beginPath();
      for (let i = 0; i < t.length; i++) (i ? g.lineTo : g.moveTo).call(g, X(t[i]), Y(x[i][k]));
      g.stroke();
    }
    if (n <= MAX_LEGEND) {
      g.textAlign = "right";
      for (let k = 0; k < n; k++) {
        g.fillStyle = COLORS[k % COLORS.length];
        g.fillText(labels[k] || `${name}[${k}]`, w - R - 2, T + 10 + 11 * k);
      }
    }
    if (cursor !== undefined) {
      g.strokeStyle = "#000"; g.beginPath(); g.moveTo(X(cursor), T); g.lineTo(X(cursor), h - B); g.stroke();
    }
  }

  // traj: {t, q, v, tau, report}; names: joint names (q's labels when q has one column per joint)
  function draw(container, traj, names, cursor) {
    const panels = ["q", "v", "tau"].filter((k) => traj[k] && traj[k].length === traj.t.length && traj[k][0] &&
                                                     traj[k][0].length);
    if (container.dataset.panels !== panels.join()) {
      container.innerHTML = "";
      for (const k of panels) {
        const c = document.createElement("canvas");
        c.dataset.name = k;
        container.appendChild(c);
      }
      container.dataset.panels = panels.join();
    }
    for (const c of container.querySelectorAll("canvas")) {
      const k = c.dataset.name, x = traj[k];
      const labels = k !== "q" || x[0].length === names.length ? names : [];
      panel(c, traj.t, x, k, labels, cursor);
    }
  }

  return {draw, reportTitle};
})();
