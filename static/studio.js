// The iCub intention studio's additions to viser's page. Loaded once per page by
// app/client_script.py (an <img> in a GUI HTML element whose onerror handler appends this
// file as a <script>: viser sets HTML elements with innerHTML, where a <script> tag never
// runs). Idempotent: a second load does nothing.
//
// 1. Keys for the 3D view only. viser's keyboard camera (WASD QE and the arrows) listens on
//    `document` and ignores only text fields, so the arrows on the "Observed %" slider (a
//    Mantine `div role="slider"`) moved the slider and orbited the camera too. React handles
//    key events at its root container, inside <body>; this listener on <body> (bubble phase)
//    runs after it and stops the event before it reaches `document`, for the camera keys and
//    Space, whenever the key goes to a GUI control (anything focused but the page itself or
//    the 3D canvas). The slider still moves; the camera stays; Space (the Record hotkey, a
//    listener on `document` too) starts or stops a recording only when the 3D view, not a
//    button or another control, has the focus. Key-up events pass: a key held over the 3D
//    view and released elsewhere must still release the camera.
//
// 2. A click on the plot area of a chart listed in the configuration (by its title) moves the
//    slider it names to the same x: it is turned into a mouse press and release on the
//    slider's track at the matching place (the track's range maps linearly), which Mantine
//    handles like a user's click, so the server hears of it the usual way.
//
// 3. showTab(title) clicks the tab so titled, as a user does. viser lets the server choose no
//    browser's tab; for the Data tab's "Open in Infer", the studio adds to the browser that
//    asked a hidden <img> whose onerror handler calls it (app/client_script.py,
//    tab_switch_html). viser's tabs (which can also be dragged) change on the pointer's
//    release, not on a bare `click()`: the whole press and release is dispatched, at the
//    middle of the tab.
//
// 4. The tab shown is reported: viser tells the server nothing of a tab chosen, so the 3D view
//    kept the look of the tab whose controls were used last (clicking Infer changed nothing
//    until a control was touched). The configuration names a row of buttons, one per tab
//    title (app/ui/page_script.py, BrowserTabs); the script hides that row and, whenever the
//    selected tab of those titles changes (a click, the keyboard, showTab), clicks its button,
//    which the server hears as any click. The tab shown when the page loads is not reported
//    (opening a page is not choosing a tab).
(function () {
  "use strict";
  const studio = (window.__icubStudio = window.__icubStudio || {});
  if (studio.loaded) return;
  studio.loaded = true;
  studio.config = studio.config || { charts: {} };

  const CAMERA_KEYS = new Set([
    "KeyW", "KeyA", "KeyS", "KeyD", "KeyQ", "KeyE",
    "ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight", "Space",
  ]);

  function inControl(target) {
    if (!(target instanceof Element)) return false;
    if (target === document.body || target === document.documentElement) return false;
    return target.tagName !== "CANVAS";
  }

  studio.stoppedKeys = 0;
  document.body.addEventListener("keydown", function (event) {
    if (CAMERA_KEYS.has(event.code) && inControl(event.target)) {
      event.stopPropagation();
      studio.stoppedKeys += 1;
    }
  });

  function chartConfig(over) {
    const plot = over.closest(".uplot");
    const title = plot && plot.querySelector(".u-title");
    return title ? studio.config.charts[title.textContent.trim()] : undefined;
  }

  function moveSlider(config, value) {
    const root = document.getElementById(config.slider);
    if (!root) return false;
    const track =
      root.querySelector(".mantine-Slider-trackContainer") ||
      root.querySelector(".mantine-Slider-track") ||
      root;
    const box = track.getBoundingClientRect();
    const fraction = Math.min(1, Math.max(0, (value - config.min) / (config.max - config.min)));
    const init = {
      bubbles: true,
      cancelable: true,
      button: 0,
      buttons: 1,
      clientX: box.left + fraction * box.width,
      clientY: box.top + box.height / 2,
      view: window,
    };
    track.dispatchEvent(new MouseEvent("mousedown", init));
    track.dispatchEvent(new MouseEvent("mouseup", Object.assign({}, init, { buttons: 0 })));
    document.dispatchEvent(new MouseEvent("mouseup", Object.assign({}, init, { buttons: 0 })));
    return true;
  }

  studio.chartClicks = 0;
  document.addEventListener("click", function (event) {
    const over = event.target instanceof Element ? event.target.closest(".u-over") : null;
    if (!over) return;
    const config = chartConfig(over);
    if (!config) return;
    const box = over.getBoundingClientRect();
    const [x0, x1] = config.x;
    const value = x0 + ((event.clientX - box.left) / box.width) * (x1 - x0);
    if (moveSlider(config, value)) studio.chartClicks += 1;
  });

  studio.tabReports = 0;
  function tabConfig() {
    return studio.config.tabs || {};
  }

  function reporterRow() {
    const report = tabConfig().report;
    const label = report && document.querySelector('label[for="' + report + '"]');
    if (!label) return null;
    let row = label.closest(".mantine-Flex-root");
    while (row && row.parentElement && !row.querySelector("button")) row = row.parentElement;
    return row;
  }

  let reported = null;
  function selectedTitle() {
    const titles = tabConfig().titles || [];
    const tab = Array.from(document.querySelectorAll('[role="tab"][aria-selected="true"]')).find(
      function (t) {
        return titles.indexOf(t.textContent.trim()) >= 0;
      },
    );
    return tab ? tab.textContent.trim() : null;
  }

  function watchTabs() {
    const row = reporterRow();
    if (row && row.parentElement && row.parentElement.style.display !== "none") {
      row.parentElement.style.display = "none";
    }
    const title = selectedTitle();
    if (title === null) return;
    if (reported === null) {
      reported = title; // the tab the page opened on: not a choice
      return;
    }
    if (title === reported || !row) return;
    const button = Array.from(row.querySelectorAll("button")).find(function (b) {
      return b.textContent.trim() === title;
    });
    if (!button) return;
    reported = title;
    button.click();
    studio.tabReports += 1;
  }
  new MutationObserver(watchTabs).observe(document.body, {
    subtree: true,
    childList: true,
    attributes: true,
    attributeFilter: ["aria-selected"],
  });
  watchTabs();

  studio.tabSwitches = 0;
  studio.showTab = function (title) {
    const tab = Array.from(document.querySelectorAll('[role="tab"]')).find(function (t) {
      return t.textContent.trim() === title;
    });
    if (!tab) return false;
    const box = tab.getBoundingClientRect();
    const init = {
      bubbles: true,
      cancelable: true,
      button: 0,
      isPrimary: true,
      pointerId: 1,
      pointerType: "mouse",
      clientX: box.left + box.width / 2,
      clientY: box.top + box.height / 2,
      view: window,
    };
    const down = Object.assign({}, init, { buttons: 1 });
    tab.dispatchEvent(new PointerEvent("pointerdown", down));
    tab.dispatchEvent(new MouseEvent("mousedown", down));
    tab.dispatchEvent(new PointerEvent("pointerup", init));
    tab.dispatchEvent(new MouseEvent("mouseup", init));
    tab.dispatchEvent(new MouseEvent("click", init));
    studio.tabSwitches += 1;
    return true;
  };
})();
