// The landing page: the library with a preview button per maneuver (opens it in the studio) and headless runs.
"use strict";

const cfg = window.FOOTFALL || {viewerPort: "8080", tokenRequired: false};
const studioUrl = `${location.protocol}//${location.hostname}:${cfg.viewerPort}/`;
document.getElementById("studio-link").href = studioUrl;

const tokenInput = document.getElementById("token");
if (cfg.tokenRequired) {
  document.getElementById("token-box").hidden = false;
  tokenInput.value = localStorage.getItem("footfall-token") || "";
  tokenInput.addEventListener("change", () => localStorage.setItem("footfall-token", tokenInput.value.trim()));
}

function headers(json) {
  const h = {};
  if (json) h["Content-Type"] = "application/json";
  const t = tokenInput.value.trim();
  if (t) h["X-Footfall-Token"] = t;
  return h;
}

async function api(method, path, body) {
  const r = await fetch(path, {method, headers: headers(body !== undefined),
                               body: body === undefined ? undefined : JSON.stringify(body)});
  let data = null;
  try { data = await r.json(); } catch (e) { data = null; }
  if (!r.ok) {
    const msg = (data && data.detail) || `${r.status} ${r.statusText}`;
    throw new Error(msg);
  }
  return data;
}

function cell(tr, text) {
  const td = document.createElement("td");
  if (text !== undefined) td.textContent = text;
  tr.appendChild(td);
  return td;
}

async function preview(name, button) {
  button.disabled = true;
  try {
    await api("POST", "/studio/preview", {maneuver: name, terrain: document.getElementById("terrain").value});
    window.open(studioUrl, "_blank");
  } catch (e) {
    alert(`Preview of ${name}: ${e.message}`);
  } finally {
    button.disabled = false;
  }
}

async function runHeadless(name, out, button) {
  button.disabled = true;
  out.textContent = "queued…";
  try {
    const job = await api("POST", "/simulations", {maneuver: name, terrain: document.getElementById("terrain").value});
    for (;;) {
      await new Promise((res) => setTimeout(res, 500));
      const j = await api("GET", `/simulations/${job.id}`);
      if (j.status === "done") {
        const r = j.report;
        out.textContent = r.success ? `✔ success (${r.timing.rtf}× real time)` : `✖ ${r.failure_reason}`;
        break;
      }
      if (j.status === "failed") { out.textContent = `✖ ${j.error}`; break; }
      const p = j.progress;
      out.textContent = p ? `${j.status} ${(100 * p.fraction).toFixed(0)} %` : j.status;
    }
  } catch (e) {
    out.textContent = `✖ ${e.message}`;
  } finally {
    button.disabled = false;
  }
}

async function load() {
  const terrains = await api("GET", "/terrains");
  const sel = document.getElementById("terrain");
  for (const t of terrains) {
    const o = document.createElement("option");
    o.value = t.name; o.textContent = t.name; o.title = t.description;
    sel.appendChild(o);
  }
  const lib = await api("GET", "/maneuvers");
  const tbody = document.querySelector("#library tbody");
  tbody.innerHTML = "";
  for (const m of lib) {
    const tr = document.createElement("tr");
    const name = cell(tr);
    name.innerHTML = `<b></b><br><small></small>`;
    name.querySelector("b").textContent = m.name;
    name.querySelector("small").textContent = m.title || "";
    cell(tr, m.duration ? `${m.duration} s` : "—");
    cell(tr, m.source);
    const b = document.createElement("button");
    b.textContent = "Preview in studio";
    b.className = "primary";
    b.onclick = () => preview(m.name, b);
    cell(tr).appendChild(b);
    const runCell = cell(tr);
    const rb = document.createElement("button");
    rb.textContent = "Run";
    const out = document.createElement("span");
    out.className = "result";
    rb.onclick = () => runHeadless(m.name, out, rb);
    runCell.append(rb, " ", out);
    if (m.problems) { b.disabled = rb.disabled = true; out.textContent = `✖ ${m.problems[0].message}`; }
    tbody.appendChild(tr);
  }
}

load().catch((e) => {
  document.querySelector("#library tbody").innerHTML = "";
  const tr = document.createElement("tr");
  cell(tr, `could not load the library: ${e.message}`).colSpan = 5;
  document.querySelector("#library tbody").appendChild(tr);
});
