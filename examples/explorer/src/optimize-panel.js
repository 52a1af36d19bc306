// The Optimize panel: objective, constraints and fixed parameters in the expression language of
// `cadinterp optimize`, run by the native server (`cadinterp explore`: POST api/optimize, Ipopt
// on the same asset); the sliders then follow the accepted iterates to x*, and the optimum's
// values are shown. Served from a static host (no endpoint) the panel says what it needs.
//
// The explorer object it drives: params (names, ranges), fields, regions, x (Float64Array),
// and moveTo(x) (sets the sliders and redraws on the next frame).

const ANIMATION_MS = 2500; // the whole path, whatever its length (at most one step per frame)
const MIN_STEP_MS = 60;

function fmt(v) {
  if (v === null || v === undefined || Number.isNaN(v)) return '–';
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e6 || a < 1e-3)) return v.toExponential(5);
  return Number(v.toPrecision(7)).toString();
}

/** A name of the expression language: bare when it is an identifier, else quoted. */
function nameToken(n) {
  return /^[A-Za-z_][A-Za-z0-9_]*$/.test(n) ? n : `'${n}'`;
}

/** The quantities of the expression language for this asset's fields and regions. */
export function quantitiesFor(fields, regions) {
  const q = ['volume', 'area', 'mass(1)', 'frontal_area(1, 0, 0)', 'centroid_x', 'centroid_y', 'centroid_z'];
  q.push('inertia_xx', 'inertia_yy', 'inertia_zz');
  for (const f of fields) {
    const n = nameToken(f.name);
    q.push(`integral(${n})`, `max(${n})`);
  }
  for (const r of regions) {
    q.push(`region_area(${nameToken(r.name)})`);
    for (const f of fields) q.push(`region_integral(${nameToken(f.name)}, ${nameToken(r.name)})`);
  }
  return q;
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

export class OptimizePanel {
  constructor(explorer, root = document) {
    this.explorer = explorer;
    this.$ = (id) => root.getElementById(id);
    this.available = null; // unknown until probe() answers
    this.running = false;
    this.animating = false;
    this.result = null;
    this.error = null;
    this.build();
  }

  build() {
    const e = this.explorer;
    const list = this.$('opt-quantities');
    const quantities = quantitiesFor(e.fields, e.regions);
    for (const q of quantities) list.appendChild(new Option(q, q));
    this.$('opt-quantity-list').textContent = quantities.join(', ');
    const stress = e.fields.find((f) => /stress|mises/i.test(f.name)) ?? e.fields[0];
    this.$('opt-objective').value = stress ? `integral(${nameToken(stress.name)})` : 'volume';
    const box = this.$('opt-fixed');
    this.fixBoxes = e.params.map((p, i) => {
      const label = document.createElement('label');
      label.className = 'row small';
      label.innerHTML = '<span><input type="checkbox"> fix <b></b></span><span class="muted"></span>';
      label.querySelector('b').textContent = p.name;
      const input = label.querySelector('input');
      input.dataset.index = String(i);
      box.appendChild(label);
      return { input, value: label.querySelector('.muted') };
    });
    this.$('opt-run').addEventListener('click', () => this.run());
  }

  /** Asks the server whether it can optimize (404 or no answer: a static host). */
  async probe() {
    let reason = 'Optimization needs `cadinterp explore`: the native server runs the optimizer ' +
      '(Ipopt) on the asset. This page is served without it.';
    try {
      const r = await fetch('api/optimize', { cache: 'no-store' });
      const type = r.headers.get('content-type') ?? '';
      if (type.includes('json')) {
        const j = await r.json();
        if (r.ok && j.available) {
          this.available = true;
          this.limits = j;
          this.$('opt-iterations').max = String(j.max_iterations);
          this.showFixedValues();
          return;
        }
        if (j.reason) reason = j.reason;
      }
    } catch {
      /* no server: the static-host message */
    }
    this.available = false;
    const m = this.$('opt-unavailable');
    m.textContent = reason;
    m.hidden = false;
    this.$('opt-form').hidden = true;
  }

  /** The slider value each fixed parameter would be fixed at. */
  showFixedValues() {
    const x = this.explorer.x;
    this.fixBoxes.forEach((b, i) => (b.value.textContent = `at ${fmt(x[i])}`));
  }

  form() {
    const e = this.explorer;
    const f = new URLSearchParams();
    f.set('objective', this.$('opt-objective').value);
    for (const line of this.$('opt-constraints').value.split('\n'))
      if (line.trim()) f.append('constraint', line.trim());
    const x = Array.from(e.x);
    const fixes = this.fixBoxes
      .map((b, i) => (b.input.checked ? `${e.params[i].name}=${x[i]}` : null))
      .filter((s) => s !== null);
    if (fixes.length) f.set('fix', fixes.join(','));
    f.set('start', x.join(','));
    f.set('max_iterations', this.$('opt-iterations').value || '100');
    return f;
  }

  async run() {
    if (this.running || !this.available) return;
    this.running = true;
    this.error = null;
    this.result = null;
    this.$('opt-run').disabled = true;
    this.$('opt-error').hidden = true;
    this.$('opt-status').textContent = 'optimizing…';
    this.$('opt-result').innerHTML = '';
    this.showFixedValues();
    try {
      const r = await fetch('api/optimize', { method: 'POST', body: this.form() });
      const j = await r.json();
      if (!r.ok) {
        this.showError(r.status, j);
        return;
      }
      this.$('opt-status').textContent = `${j.result.status}; moving the sliders along the iterates…`;
      await this.animate(j.result.path.map((p) => p.x), j.parameters.map((n) => j.result.x[n]));
      this.result = j;
      this.showResult(j);
    } catch (e) {
      this.showError(0, { error: `the request failed: ${e.message}` });
    } finally {
      this.running = false;
      this.$('opt-run').disabled = false;
    }
  }

  /** Moves the sliders through the iterates, then to x*. */
  async animate(path, xStar) {
    this.animating = true;
    const steps = path.length ? path : [];
    const stride = Math.max(1, Math.ceil((steps.length * MIN_STEP_MS) / ANIMATION_MS));
    const dt = Math.max(MIN_STEP_MS, ANIMATION_MS / Math.max(1, steps.length));
    for (let k = 0; k < steps.length; k += stride) {
      this.explorer.moveTo(steps[k]);
      await sleep(dt);
    }
    this.explorer.moveTo(xStar);
    this.animating = false;
  }

  showError(status, j) {
    const box = this.$('opt-error');
    const head = j.input ? `${j.input}: ${j.error}` : j.error ?? `HTTP ${status}`;
    box.textContent = '';
    box.appendChild(document.createTextNode(head));
    if (j.text) {
      const pre = document.createElement('pre');
      pre.textContent = j.column > 0 ? `${j.text}\n${' '.repeat(j.column - 1)}^` : j.text;
      box.appendChild(pre);
    }
    box.hidden = false;
    this.error = { status, ...j };
    this.$('opt-status').textContent = status === 409 ? 'the server is busy' : 'not run';
  }

  showResult(j) {
    const r = j.result;
    const rows = [
      ['status', `${r.status}${r.converged ? '' : ' (not converged)'}`],
      [`minimize ${r.objective_expression}`, fmt(r.objective)],
      ...r.constraints.map((c) => [c.expression, fmt(c.value)]),
      ...j.parameters.map((n) => [`x* ${n}`, fmt(r.x[n])]),
      ['iterations, evaluations', `${r.iterations}, ${r.evaluations}${r.refused_evaluations ? ` (${r.refused_evaluations} refused by a wall)` : ''}`],
      ['error estimate at x*', r.error_estimate >= 0 ? `${fmt(100 * r.error_estimate)} % of bbox diagonal` : 'not measured'],
      ['time', `${fmt(j.seconds * 1000)} ms (server)`],
    ];
    if (r.constraint_violation > 1e-6) rows.splice(2 + r.constraints.length, 0, ['violation', `${fmt(r.constraint_violation)} (constraints NOT met)`]);
    if (r.linear_asset) rows.push(['note', r.note]);
    const t = this.$('opt-result');
    t.innerHTML = rows.map(() => '<tr><td></td><td></td></tr>').join('');
    rows.forEach(([k, v], i) => {
      t.rows[i].cells[0].textContent = k;
      t.rows[i].cells[1].textContent = v;
    });
    this.$('opt-status').textContent = 'done: the sliders are at x*';
  }

  /** For the test hook. */
  state() {
    return {
      available: this.available,
      running: this.running,
      animating: this.animating,
      result: this.result,
      error: this.error,
      status: this.$('opt-status').textContent,
      unavailableMessage: this.$('opt-unavailable').hidden ? '' : this.$('opt-unavailable').textContent,
    };
  }
}
