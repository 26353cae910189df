// footfall's helper in the studio page (viser's viewer), run once per tab from an HTML element of the GUI.
// 1. Ties every label to its input: viser's text inputs carry their own id, not the one their label points to, so a
//    screen reader (or a test's get_by_label) found no name for "save as name" or "API token".
// 2. The timeline you work on with the mouse: drag a swing bar (move), its ends (liftoff, touchdown), a touchdown's
//    shaded adjust window (its ± time), a keyframe diamond; click to select (shift adds), drag on empty rows to box
//    select, drag on the time axis to move the playhead, wheel to zoom, shift+wheel to pan. Each gesture is sent to
//    the server as one JSON op through the hidden "timeline edits" text input; the server snaps, applies, redraws.
// 3. The loaded music plays in step with the preview: the server writes the preview's time, speed and state into a
//    hidden clock element a few times a second; between writes the time runs on at that speed here; the audio is
//    started, sought (when off by more than 0.15 s) and paused to follow it.
(function () {
  if (window.__footfall) return;
  var ff = (window.__footfall = {n: 0});

  function tieLabels() {
    document.querySelectorAll("label[for]").forEach(function (label) {
      var target = label.getAttribute("for");
      if (!target || document.getElementById(target)) return;
      var row = label.parentElement;
      for (var i = 0; i < 4 && row && !row.querySelector("input, textarea"); i++) row = row.parentElement;
      var input = row && row.querySelector("input:not([type=hidden]), textarea");
      if (!input || input.getAttribute("aria-labelledby")) return;
      if (!label.id) label.id = "footfall-label-" + target;
      input.setAttribute("aria-labelledby", label.id);
      if (label.textContent === "timeline edits") {
        ff.bridge = input;
        var box = row;
        while (box && box.parentElement && box.parentElement.children.length === 1) box = box.parentElement;
        if (box) box.style.display = "none";
      }
    });
  }
  tieLabels();
  new MutationObserver(tieLabels).observe(document.body, {childList: true, subtree: true});

  function send(op) {
    var input = ff.bridge;
    if (!input || !input.isConnected) return;
    ff.n += 1;
    op.n = ff.n;
    var setter = Object.getOwnPropertyDescriptor(window.HTMLInputElement.prototype, "value").set;
    setter.call(input, JSON.stringify(op));
    input.dispatchEvent(new Event("input", {bubbles: true}));
  }
  ff.send = send;

  function geom(svg) {
    var r = svg.getBoundingClientRect();
    var d = svg.dataset;
    var scale = parseFloat(d.width) / r.width;
    var v0 = parseFloat(d.v0), v1 = parseFloat(d.v1), left = parseFloat(d.left), inner = parseFloat(d.inner);
    return {
      rect: r, scale: scale, v0: v0, v1: v1,
      t: function (clientX) { return v0 + ((clientX - r.left) * scale - left) / inner * (v1 - v0); },
      secPerPx: scale / inner * (v1 - v0),
    };
  }

  var drag = null;
  document.addEventListener("pointerdown", function (e) {
    var svg = e.target.closest && e.target.closest("svg[data-footfall-timeline]");
    if (!svg || e.button !== 0) return;
    e.preventDefault();
    e.stopPropagation();
    var el = e.target;
    var part = el.getAttribute("data-part") || "background";
    var ids = (el.getAttribute("data-ids") || "").split(" ").filter(Boolean);
    var g = geom(svg);
    drag = {svg: svg, el: el, part: part, ids: ids, x0: e.clientX, y0: e.clientY, g: g, shift: e.shiftKey, moved: false};
    if (part === "playhead") send({op: "scrub", t: g.t(e.clientX)});
    if (part === "background") {
      var box = document.createElementNS("http://www.w3.org/2000/svg", "rect");
      box.setAttribute("fill", "rgba(76,201,240,0.15)");
      box.setAttribute("stroke", "#4cc9f0");
      box.setAttribute("pointer-events", "none");
      svg.appendChild(box);
      drag.box = box;
    }
  }, true);

  document.addEventListener("pointermove", function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x0, dy = e.clientY - drag.y0;
    if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
    var s = drag.g.scale;
    if (drag.part === "playhead") {
      send({op: "scrub", t: drag.g.t(e.clientX)});
    } else if (drag.box) {
      var r = drag.g.rect;
      var x0 = (Math.min(drag.x0, e.clientX) - r.left) * s, y0 = (Math.min(drag.y0, e.clientY) - r.top) * s;
      drag.box.setAttribute("x", x0);
      drag.box.setAttribute("y", y0);
      drag.box.setAttribute("width", Math.abs(dx) * s);
      drag.box.setAttribute("height", Math.abs(dy) * s);
    } else if (drag.ids.length) {
      drag.el.setAttribute("transform", "translate(" + dx * s + " 0)");  // follows the pointer until released
    }
  }, true);

  document.addEventListener("pointerup", function (e) {
    if (!drag) return;
    var d = drag;
    drag = null;
    var dt = (e.clientX - d.x0) * d.g.secPerPx;
    if (d.box) {
      var r = d.box.getBoundingClientRect();
      d.box.remove();
      if (!d.moved) { if (!d.shift) send({op: "select", ids: []}); return; }
      var ids = [];
      d.svg.querySelectorAll("[data-ids][data-part=move]").forEach(function (el) {
        var b = el.getBoundingClientRect();
        var cx = b.left + b.width / 2, cy = b.top + b.height / 2;
        if (cx >= r.left && cx <= r.right && cy >= r.top && cy <= r.bottom) {
          ids = ids.concat(el.getAttribute("data-ids").split(" "));
        }
      });
      send({op: "select", ids: ids, add: d.shift});
    } else if (d.ids.length) {
      d.el.removeAttribute("transform");
      if (d.moved) send({op: "drag", ids: d.ids, part: d.part, dt: dt});
      else send({op: "select", ids: d.ids, add: d.shift});
    }
  }, true);

  document.addEventListener("wheel", function (e) {
    var svg = e.target.closest && e.target.closest("svg[data-footfall-timeline]");
    if (!svg) return;
    e.preventDefault();
    e.stopPropagation();
    var g = geom(svg);
    var span = g.v1 - g.v0, dur = parseFloat(svg.dataset.duration);
    var t0, t1;
    if (e.shiftKey) {  // pan
      var shift = (e.deltaY || e.deltaX) > 0 ? span * 0.2 : -span * 0.2;
      t0 = Math.max(0, Math.min(dur - span, g.v0 + shift));
      t1 = t0 + span;
    } else {  // zoom about the pointer
      var at = g.t(e.clientX), k = e.deltaY > 0 ? 1.25 : 0.8;
      var ns = Math.min(dur, Math.max(0.1, span * k));
      t0 = Math.max(0, at - (at - g.v0) * ns / span);
      t1 = Math.min(dur, t0 + ns);
      t0 = Math.max(0, t1 - ns);
    }
    send({op: "view", t0: t0, t1: t1});
  }, {capture: true, passive: false});

  var clock = {run: null, t: 0, at: 0, playing: false, rate: 1};
  function syncAudio() {
    var audio = document.querySelector("audio[data-footfall-audio]");
    var el = document.querySelector("[data-footfall-clock]");
    if (!audio || !el) return;
    var d = el.dataset, t = parseFloat(d.t) || 0, now = performance.now() / 1000;
    if (d.t !== clock.raw || d.playing !== clock.rawPlaying || d.run !== clock.run) {
      clock = {raw: d.t, rawPlaying: d.playing, run: d.run, t: t, at: now, playing: d.playing === "1",
               rate: parseFloat(d.rate) || 1};
    }
    var want = clock.playing ? clock.t + (now - clock.at) * clock.rate : clock.t;
    ff.audioTarget = want;
    if (!clock.playing) {
      if (!audio.paused) audio.pause();
      return;
    }
    if (want >= (audio.duration || Infinity)) return;
    audio.playbackRate = Math.min(4, Math.max(0.25, clock.rate));
    if (Math.abs(audio.currentTime - want) > 0.15) audio.currentTime = want;
    if (audio.paused) {
      var p = audio.play();
      if (p && p.catch) p.catch(function () {});  // a tab nobody clicked in may not play sound yet
    }
  }
  setInterval(syncAudio, 100);
})();
