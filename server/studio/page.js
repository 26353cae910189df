// footfall's helper in the studio page (viser's viewer), run once per tab from an HTML element of the GUI.
// Ties every label to its input: viser's text inputs carry their own id, not the one their label points to, so a
// screen reader (or a test's get_by_label) found no name for "save as name" or "API token".
(function () {
  if (window.__footfall) return;
  window.__footfall = {};
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
    });
  }
  tieLabels();
  new MutationObserver(tieLabels).observe(document.body, {childList: true, subtree: true});
})();
