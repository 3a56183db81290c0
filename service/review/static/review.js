// The review screen updates itself in place (plain JavaScript, no build step).
// Every period it fetches /review/live and swaps in the sections, queue, silent devices,
// recent runs, the run's evidence and the action buttons. The reason box is never part of
// what is swapped, so a typed reason is kept. If no update arrives within twice the period,
// the page says so (banner, greyed states): a screen that cannot update must not look current.
// A new alarm or review sounds (once "Enable sound" was clicked: browsers require a click),
// raises a browser notification when permitted, and flashes the header.
(function () {
  "use strict";
  var screen = document.getElementById("screen");
  if (!screen) { return; }
  var period = Number(screen.dataset.refreshS) * 1000;
  var lastOk = Date.now();
  var body = document.body;
  var banner = document.getElementById("stale-banner");
  var updated = document.getElementById("updated");
  var staleSince = document.getElementById("stale-since");
  var soundButton = document.getElementById("sound");
  var audio = document.getElementById("alert-sound");
  var seen = {};
  JSON.parse(document.getElementById("initial-alerts").textContent).forEach(function (a) {
    seen[a.run + ":" + a.state] = true;
  });
  body.dataset.alerts = "0";
  body.dataset.sounded = "0";
  body.dataset.notified = "0";

  function count(name) { body.dataset[name] = String(Number(body.dataset[name]) + 1); }

  function soundOn() { return window.localStorage.getItem("depot-sound") === "on"; }

  function showSound() {
    soundButton.setAttribute("aria-pressed", soundOn() ? "true" : "false");
    soundButton.textContent = soundOn() ? "Sound on" : "Enable sound";
  }

  function play() {
    audio.currentTime = 0;
    var played = audio.play();
    if (played && played.then) {
      played.then(function () {
        count("sounded");
        soundButton.classList.remove("blocked");
      }, function () {
        // The browser refused (no click on this page yet): say so on the control.
        soundButton.classList.add("blocked");
        soundButton.textContent = "Sound blocked: click";
      });
    }
  }

  soundButton.addEventListener("click", function () {
    window.localStorage.setItem("depot-sound", soundOn() ? "off" : "on");
    showSound();
    if (soundOn()) {
      play(); // also the test of the sound, and the click that unlocks it
      if ("Notification" in window && Notification.permission === "default") {
        Notification.requestPermission();
      }
    }
  });
  showSound();

  function ring(fresh) {
    count("alerts");
    body.classList.remove("ringing");
    void body.offsetWidth; // restart the animation
    body.classList.add("ringing");
    if (soundOn()) { play(); }
    if ("Notification" in window && Notification.permission === "granted") {
      fresh.forEach(function (a) {
        var what = a.state === "alarm" ? "ALARM" : "needs review";
        new Notification("Section " + a.section + ": " + what, {
          body: "train " + a.train + " (run " + a.run + ")",
          tag: "depot-" + a.run + "-" + a.state,
        });
        count("notified");
      });
    }
  }

  function alerts(list) {
    var fresh = list.filter(function (a) { return !seen[a.run + ":" + a.state]; });
    list.forEach(function (a) { seen[a.run + ":" + a.state] = true; });
    if (fresh.length) { ring(fresh); }
  }

  function apply(data) {
    Object.keys(data.fragments).forEach(function (name) {
      var part = document.getElementById("frag-" + name);
      if (part) { part.innerHTML = data.fragments[name]; }
    });
    if (data.run !== null && !screen.dataset.run) {
      // No run was shown: show the oldest waiting one, and aim the form at it.
      screen.dataset.run = String(data.run);
      var form = document.getElementById("decide");
      if (form) { form.setAttribute("action", "/review/runs/" + data.run + "/decision"); }
    }
    document.title = data.title;
    updated.textContent = "updated " + data.updated;
    staleSince.textContent = data.updated;
    alerts(data.alerts);
  }

  function update() {
    var url = "/review/live" + (screen.dataset.run ? "?run=" + screen.dataset.run : "");
    var abort = new AbortController();
    var timer = window.setTimeout(function () { abort.abort(); }, period);
    return fetch(url, { credentials: "same-origin", cache: "no-store", signal: abort.signal }).then(function (response) {
      if (response.status === 401) {
        banner.textContent = "Your session has ended: log in again to see the line.";
        throw new Error("logged out");
      }
      if (!response.ok) { throw new Error("HTTP " + response.status); }
      return response.json();
    }).then(function (data) {
      apply(data);
      lastOk = Date.now();
      watch();
    }).catch(function () { watch(); }).then(function () {
      window.clearTimeout(timer);
    });
  }

  function poll() {
    update().then(function () { window.setTimeout(poll, period); });
  }

  function isStale() { return Date.now() - lastOk > 2 * period; }

  function watch() {
    var stale = isStale();
    body.classList.toggle("stale", stale);
    banner.hidden = !stale;
    // A decision taken on a screen that stopped updating is taken on old evidence: the
    // action buttons wait until the screen is current again.
    document.querySelectorAll("button.act").forEach(function (button) {
      button.disabled = stale;
    });
  }

  var refusal = document.getElementById("decision-refusal");

  function refuse(message) {
    refusal.textContent = message;
    refusal.hidden = false;
  }

  // A decision is sent with the revision of the run the page shows (the hidden "seen" of the
  // actions). Refused because the run changed (or for any reason), the refusal is shown in
  // place and the run read again at once; the typed reason stays in its box.
  function send(form, button) {
    var data = new URLSearchParams(new FormData(form));
    data.set("action", button.value);
    document.querySelectorAll("button.act").forEach(function (b) { b.disabled = true; });
    // getAttribute: the buttons named "action" shadow the form's own form.action
    fetch(form.getAttribute("action"), {
      method: "POST", body: data, credentials: "same-origin", cache: "no-store",
      headers: { Accept: "application/json" },
    }).then(function (response) {
      if (response.status === 401) { window.location.assign("/review/login"); return null; }
      return response.json().then(function (answer) {
        if (response.ok && answer.ok) { window.location.assign(answer.next); return; }
        refuse(answer.message || answer.detail || ("Refused (HTTP " + response.status + "): nothing was recorded."));
        return update();
      });
    }).catch(function () {
      refuse("The decision may not have reached the server: look at the run again before acting.");
      return update();
    });
  }

  document.addEventListener("submit", function (event) {
    var form = event.target;
    var button = event.submitter;
    if (form.id !== "decide") {
      return;
    }
    if (isStale()) {
      // The banner says "do not act on them": a decision on this screen is not sent at all.
      event.preventDefault();
      refuse("This screen is not current: nothing was sent. Wait until it updates, then look again.");
      return;
    }
    if (button && button.dataset.confirm && !window.confirm(button.dataset.confirm)) {
      event.preventDefault();
      return;
    }
    if (button && window.fetch) {
      event.preventDefault();
      refusal.hidden = true;
      send(form, button);
    }
  });

  window.setInterval(watch, 1000);
  window.setTimeout(poll, period);
})();
