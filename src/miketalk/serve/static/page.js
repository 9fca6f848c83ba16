// miketalk serve: the page. Plain JavaScript, no library; every text from the server or
// the user is put in the page as text (textContent), never as HTML.
"use strict";

const $ = (selector, root = document) => root.querySelector(selector);
const $$ = (selector, root = document) => Array.from(root.querySelectorAll(selector));

const SHAPES = {
  A: "closed (P, B, M)", B: "slightly open (K, S, T, EE)", C: "open (EH, AE)",
  D: "wide open (AA)", E: "rounded (AO, ER)", F: "puckered (UW, OW, W)",
  G: "teeth on lip (F, V)", H: "tongue up (L)", X: "rest",
};
const FINAL = new Set(["done", "failed", "cancelled", "interrupted"]);

const state = { config: null, models: [], model: null, build: null, shown: null };

// -- talking to the server

async function api(path, options = {}) {
  const headers = { "X-Miketalk": "1", ...(options.headers || {}) };
  let response;
  try {
    response = await fetch(path, { ...options, headers });
  } catch (err) {
    throw new Error("the server cannot be reached: is miketalk serve still running?");
  }
  let doc = null;
  try { doc = await response.json(); } catch (err) { doc = null; }
  if (!response.ok) throw new Error((doc && doc.error) || `the server answered ${response.status}`);
  return doc;
}

function post(path, body) {
  return api(path, {
    method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(body || {}),
  });
}

function megabytes(n) {
  return `${(n / 1048576).toFixed(1).replace(/\.0$/, "")} MB`;
}

// An upload: the file's bytes as the body, its name in a header (shown, never a path).
function upload(file, kind, busy) {
  const limit = state.config.max_upload_bytes;
  if (file.size > limit) {
    return Promise.reject(new Error(
      `${file.name} is ${megabytes(file.size)}: larger than the upload limit of ` +
      `${megabytes(limit)} (miketalk serve --max-upload-mb)`));
  }
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open("POST", `/api/upload?kind=${encodeURIComponent(kind)}`);
    xhr.setRequestHeader("X-Miketalk", "1");
    xhr.setRequestHeader("X-Miketalk-Name", encodeURIComponent(file.name));
    xhr.setRequestHeader("Content-Type", "application/octet-stream");
    xhr.upload.onprogress = (e) => {
      if (e.lengthComputable && busy) {
        busy(`sending ${file.name}: ${Math.round((100 * e.loaded) / e.total)} %`);
      }
    };
    xhr.onload = () => {
      let doc = null;
      try { doc = JSON.parse(xhr.responseText); } catch (err) { doc = null; }
      if (xhr.status >= 200 && xhr.status < 300 && doc) resolve(doc);
      else reject(new Error((doc && doc.error) || `the upload failed (${xhr.status})`));
    };
    xhr.onerror = () => reject(new Error(`the upload of ${file.name} failed: is the server running?`));
    xhr.send(file);
  });
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// Ask for a job until it ends; onUpdate sees every state.
async function follow(id, onUpdate, every) {
  for (;;) {
    const job = await api(`/api/jobs/${encodeURIComponent(id)}`);
    onUpdate(job);
    if (FINAL.has(job.status)) return job;
    await sleep(every);
  }
}

// -- models

async function loadModels(select) {
  state.models = await api("/api/models");
  const list = $("#models");
  list.replaceChildren();
  $("#no-models").hidden = state.models.length > 0;
  for (const model of state.models) {
    const item = document.createElement("li");
    item.setAttribute("role", "radio");
    item.tabIndex = 0;
    item.dataset.id = model.id;
    const image = document.createElement("img");
    image.src = model.image;
    image.alt = "";
    image.loading = "lazy";
    image.onerror = () => { image.style.visibility = "hidden"; };
    const text = document.createElement("div");
    const name = document.createElement("div");
    name.className = "name";
    name.textContent = model.label;
    const what = document.createElement("div");
    what.className = "what";
    const origin = { workflow: "workflow", built: "built here", given: "given" }[model.source];
    what.textContent = `${model.person ? "a person" : "a still face"} · ${origin} · ` +
      model.lipsync_models.join(", ");
    text.append(name, what);
    item.append(image, text);
    item.addEventListener("click", () => chooseModel(model.id));
    item.addEventListener("keydown", (e) => {
      if (e.key === "Enter" || e.key === " ") { e.preventDefault(); chooseModel(model.id); }
    });
    list.append(item);
  }
  const keep = select || (state.model && state.model.id);
  const first = state.models.find((m) => m.id === keep) || state.models[0] || null;
  chooseModel(first ? first.id : null);
}

function chooseModel(id) {
  state.model = state.models.find((m) => m.id === id) || null;
  for (const item of $$("#models li")) {
    item.setAttribute("aria-checked", String(item.dataset.id === id));
  }
  for (const label of $$(".chosen")) {
    label.textContent = state.model ? state.model.label : "none chosen";
  }
  if (dubsOwn()) $("#dub-form .chosen").textContent = "the video's own";
  for (const form of [$("#say-form"), $("#dub-form")]) fillLipsync(form);
  const person = Boolean(state.model && state.model.person);
  $(".person-only", $("#dub-form")).hidden = person || !state.model || dubsOwn();
  $("#dub-form button[type=submit]").disabled = !person && !dubsOwn();
  $("#say-form button[type=submit]").disabled = !state.model;
}

// A dub with the video's own face: built from the video itself (the first time; kept for the
// next dub of the same video), no face of the list needed.
function dubsOwn() {
  return $("#dub-form input[name=own]").checked;
}

function fillLipsync(form) {
  const select = $("select[name=lipsync]", form);
  const recorded = Boolean($("input[name=audio]", form).files.length);
  const keep = select.value;
  select.replaceChildren();
  const model = form.id === "dub-form" && dubsOwn() ? null : state.model;  // not built yet
  const own = model ? (recorded ? model.own_recording : model.own_text) : null;
  select.append(new Option(own ? `the model's own (${own})` : "the model's own", ""));
  for (const name of (model ? model.lipsync_models : [])) select.append(new Option(name, name));
  select.value = $$("option", select).some((o) => o.value === keep) ? keep : "";
}

// -- forms

function setBusy(form, text) {
  const busy = $(".busy", form);
  busy.hidden = !text;
  busy.textContent = text || "";
  $("button[type=submit]", form).disabled = Boolean(text) ||
    (form.id === "build-form" && Boolean(state.build)) ||
    (form.id === "say-form" && !state.model) ||
    (form.id === "dub-form" && !dubsOwn() && !(state.model && state.model.person));
}

function showError(form, message) {
  const line = $(".error", form);
  line.textContent = message ? `error: ${message}` : "";
  line.hidden = !message;
}

// The text's limits (words, as the library counts them, and characters), stated in the page
// before any work, with the count of what is typed. Returns the line refusing it, or null.
function showCount(form) {
  const text = $("textarea[name=text]", form).value;
  const line = $(".limit", form);
  if (!line || !state.config) return null;
  const chars = state.config.max_text_chars;
  const words = state.config.max_text_words;
  const n = (text.match(/[A-Za-z0-9']+/g) || []).length;
  const en = (x) => x.toLocaleString("en");
  $(".max", line).textContent = en(chars);
  $(".max-words", line).textContent = en(words);
  let refusal = null;
  if (n > words) refusal = `the text has ${en(n)} words: at most ${en(words)}`;
  else if (text.length > chars) refusal = `the text is ${en(text.length)} characters long: at most ${en(chars)}`;
  $(".count", line).textContent = text.length ?
    `(${en(n)} words, ${en(text.length)} characters now${refusal ? ": too many" : ""})` : "";
  line.classList.toggle("over", Boolean(refusal));
  return refusal;
}

// What the page saw of the live playback (read by the tests and the bench).
function noteLive(key, value) {
  $("#player").dataset[key] = String(value);
}

// Speak (or Dub): the job is queued, and played as it is made (live.js); Stop ends it.
async function submitSpeech(form, kind) {
  showError(form, null);
  const own = kind === "dub" && dubsOwn();
  if (!state.model && !own) { showError(form, "choose a face in the list first"); return; }
  const refusal = showCount(form);
  if (refusal) { showError(form, `${refusal}; nothing was sent or cut`); return; }
  const clicked = performance.now();
  stopPlaying();
  state.shown = null;
  const section = $("#result");
  section.hidden = true;  // until this job plays
  delete section.dataset.job;
  const player = $("#player");
  for (const key of Object.keys(player.dataset)) delete player.dataset[key];
  let playing = null;
  try {
    setBusy(form, "starting");
    const body = {
      kind, model: own ? null : state.model.id, text: $("textarea[name=text]", form).value,
      lipsync: $("select[name=lipsync]", form).value, live: true,
    };
    const audio = $("input[name=audio]", form).files[0];
    if (audio) body.audio = (await upload(audio, "audio", (t) => setBusy(form, t))).upload;
    else body.voice = $("select[name=voice]", form).value;
    if (kind === "dub") {
      const video = $("input[name=video]", form).files[0];
      if (!video) throw new Error("choose the video to dub");
      body.video = (await upload(video, "video", (t) => setBusy(form, t))).upload;
    }
    const job = await post("/api/jobs", body);
    noteLive("job", job.id);
    noteLive("posted", ((performance.now() - clicked) / 1000).toFixed(3));
    refreshJobs();
    playing = startLive(job, clicked, kind);
    const done = await follow(job.id, (j) => {
      setBusy(form, j.status === "queued" ? `queued: ${ordinal(j.position)} in line` :
        `${j.stage || j.status}${j.elapsed ? ` (${j.elapsed.toFixed(1)} s)` : ""}`);
    }, 150);
    if (done.status === "done") {
      await playing.done.catch(() => { /* its end is the job's */ });
      showResult(done, clicked, true, true);
    } else if (done.status === "cancelled" && state.live && state.live.stopped) {
      $("#live-state").textContent = "Stopped: nothing of it was kept.";
    } else {
      stopPlaying();
      section.hidden = true;
      showError(form, done.message || done.status);
    }
  } catch (err) {
    stopPlaying();
    showError(form, err.message);
  } finally {
    setBusy(form, null);
    refreshJobs();
    // the button was disabled while it worked: the focus goes back to it, not to the body
    if (document.activeElement === document.body) $("button[type=submit]", form).focus();
  }
}

// The live player of `job`: the result shown at once, the Stop button on, the first frame's
// time noted.
function startLive(job, clicked, kind) {
  const section = $("#result");
  const player = $("#player");
  section.hidden = false;
  $(".summary", section).textContent = "";
  $(".downloads", section).hidden = true;
  $(".cue-now", section).hidden = true;  // the cues come with the whole, at its end
  $("#cues").hidden = true;
  drawCues([], 1);
  drawWarnings($(".warnings", section), []);
  const handle = playLive(player, job.live, {
    onFirstFrame: (t) => {
      noteLive("firstFrame", ((t - clicked) / 1000).toFixed(3));
      noteLive("firstByte", ((handle.stats.firstByte - clicked) / 1000).toFixed(3));
      noteLive("sinceClick", ((t - clicked) / 1000).toFixed(2));
      $("#live-state").textContent = "Playing as it is made";
      // what changed above it since Speak (the jobs, the form's state) may have moved it
      const top = section.getBoundingClientRect().top;
      if (top < -1 || top > innerHeight / 2) section.scrollIntoView({ block: "start", behavior: "instant" });
    },
  });
  state.live = { job: job.id, handle, stopped: false };
  const stop = $("#stop");
  stop.hidden = false;
  stop.disabled = false;
  const live = $("#live-state");
  live.className = "live-state on";
  live.textContent = job.status === "queued" && job.position ?
    `Queued: ${ordinal(job.position)} in line` : "Starting";
  $("#announce").textContent = `${kind === "dub" ? "Dubbing" : "Speaking"}: the face plays as it is made. Stop ends it.`;
  stop.focus({ preventScroll: true });
  section.scrollIntoView({ block: "start", behavior: "instant" });
  handle.done.then(() => {
    const { stats } = handle;
    noteLive("stalls", stats.stalls);
    noteLive("stalledSeconds", stats.stalledSeconds.toFixed(3));
    noteLive("liveBytes", stats.bytes);
    noteLive("liveEnded", "1");
  }, (err) => {
    if (!state.live || !state.live.stopped) $("#live-state").textContent = `The stream broke off: ${err.message}`;
  }).finally(() => {
    stop.hidden = true;
    live.className = "live-state";
    if (live.textContent.startsWith("Playing") || live.textContent === "Starting") live.textContent = "";
  });
  // the viewer's waits for data, as they happen (a long text: none expected)
  player.addEventListener("waiting", () => noteLive("stalls", handle.stats.stalls));
  return handle;
}

// Stop: the playback at once, then the job (its work and processes) on the server; the time
// until the server says it has ended is noted.
async function stopLive() {
  const live = state.live;
  if (!live || live.stopped) return;
  live.stopped = true;
  const asked = performance.now();
  live.handle.stop();
  $("#stop").disabled = true;
  $("#live-state").className = "live-state";
  $("#live-state").textContent = "Stopping";
  try {
    await post(`/api/jobs/${encodeURIComponent(live.job)}/cancel`);
    for (;;) {
      const job = await api(`/api/jobs/${encodeURIComponent(live.job)}`);
      if (FINAL.has(job.status)) {
        noteLive("stopSeconds", ((performance.now() - asked) / 1000).toFixed(3));
        if (job.stopped_in !== null) noteLive("stoppedIn", job.stopped_in);
        $("#live-state").textContent = job.status === "cancelled" ?
          "Stopped: nothing of it was kept." : `It had ended (${job.status}).`;
        $("#announce").textContent = "Stopped.";
        break;
      }
      await sleep(20);
    }
  } catch (err) {
    $("#live-state").textContent = `error: ${err.message}`;
  }
  refreshJobs();
}

function stopPlaying() {
  if (state.live && !state.live.stopped) state.live.handle.stop();
  $("#stop").hidden = true;
  $("#player").pause();
}

async function submitBuild(form) {
  showError(form, null);
  const video = $("input[name=video]", form).files[0];
  const script = $("input[name=script]", form).files[0];  // none: its words are recognized
  try {
    if (!video) throw new Error("choose the video of the person to build the face from");
    setBusy(form, "starting");
    const body = { kind: "build", name: $("input[name=name]", form).value };
    body.video = (await upload(video, "video", (t) => setBusy(form, t))).upload;
    if (script) body.script = (await upload(script, "script", (t) => setBusy(form, t))).upload;
    const job = await post("/api/jobs", body);
    setBusy(form, null);
    refreshJobs();
    await watchBuild(job);
  } catch (err) {
    showError(form, err.message);
  } finally {
    setBusy(form, null);
  }
}

async function watchBuild(job) {
  const form = $("#build-form");
  const box = $("#build-progress");
  state.build = job.id;
  delete box.dataset.ended;
  box.hidden = false;
  $("button[type=submit]", form).disabled = true;  // one build at a time
  $(".outcome", box).textContent = "";
  $(".label", box).textContent = job.inputs.name || "";
  $("#cancel-build").disabled = false;
  drawBuild(job);
  const done = await follow(job.id, drawBuild, 400);
  state.build = null;
  $("#cancel-build").disabled = true;
  $("button[type=submit]", form).disabled = false;
  refreshJobs();
  if (done.status === "done") {
    $(".outcome", box).textContent =
      `Built ${done.result.label} in ${Math.round(done.result.seconds)} s: it is in the list of faces.`;
    await loadModels(form.hidden ? undefined : done.result.model);  // chosen if watched
  } else if (done.status === "cancelled") {
    $(".outcome", box).textContent = "Cancelled: no model was written.";
  } else {
    $(".outcome", box).textContent = "The build failed.";
    showError(form, done.message || done.status);
  }
  box.dataset.ended = done.status;  // all said and done (the list of faces too)
}

function drawBuild(job) {
  const box = $("#build-progress");
  const done = new Map(job.stages.map((s) => [s.name, s.seconds]));
  const names = [...job.all_stages, ...job.stages.map((s) => s.name).filter((n) => !job.all_stages.includes(n))];
  const list = $(".stages", box);
  list.replaceChildren();
  for (const name of names) {
    const item = document.createElement("li");
    const label = document.createElement("span");
    label.textContent = name;
    const secs = document.createElement("span");
    secs.className = "secs";
    if (done.has(name)) {
      item.className = "done";
      secs.textContent = `${done.get(name).toFixed(1)} s`;
    } else if (job.status === "running" && name === job.stage) {
      item.className = "running";
    }
    item.append(label, secs);
    list.append(item);
  }
  const percent = Math.round(100 * (job.progress || 0));
  $(".fill", box).style.width = `${percent}%`;
  $(".bar", box).setAttribute("aria-valuenow", String(percent));
  const stage = job.status === "running" ? (job.stage || "") : job.status;
  drawWarnings($(".warnings", box), job.warnings);
  $(".elapsed", box).textContent =
    `${stage}${job.elapsed ? ` · ${Math.round(job.elapsed)} s in all` : ""}`;
  box.dataset.status = job.status;
  $("#tab-build").classList.toggle("running", !FINAL.has(job.status));
}

// -- the result: the video, its downloads, its mouth cues

function ordinal(n) {
  if (!n) return "";
  const tail = (n % 100 >= 11 && n % 100 <= 13) ? "th" : ({ 1: "st", 2: "nd", 3: "rd" }[n % 10] || "th");
  return `${n}${tail}`;
}

function drawWarnings(list, warnings) {
  list.replaceChildren();
  for (const line of warnings || []) {
    const item = document.createElement("li");
    item.textContent = line;
    list.append(item);
  }
}

// Speak's result: announced (aria-live), the focus on it and on the screen (a phone's too).
function showResult(job, clicked, announce, live) {
  const result = job.result;
  const section = $("#result");
  section.hidden = false;
  state.shown = job;
  const player = $("#player");
  if (!live) {  // a live job's stream plays on: the same frames as its file
    stopPlaying();
    player.src = job.files[result.video];
  }
  player.dataset.job = job.id;
  section.dataset.job = job.id;
  $(".downloads", section).hidden = false;
  $(".cue-now", section).hidden = false;
  $("#cues").hidden = false;
  if (clicked !== undefined && !live) {
    player.addEventListener("playing", () => {
      player.dataset.sinceClick = ((performance.now() - clicked) / 1000).toFixed(2);
    }, { once: true });
    player.play().catch(() => { /* autoplay refused: the controls are there */ });
  }
  $(".summary", section).textContent =
    `${job.kind === "dub" ? "Dubbed" : "Said"} with ${job.inputs.model}: ${result.summary}`;
  const links = {
    "#get-mp4": result.video, "#get-timeline": result.timeline,
    "#get-cues": result.cues_json, "#get-tsv": result.cues_tsv,
  };
  for (const [selector, name] of Object.entries(links)) {
    $(selector).href = `${job.files[name]}?download`;
    $(selector).download = (job.downloads && job.downloads[name]) || name;
  }
  drawCues(result.cues, result.duration);
  drawWarnings($(".warnings", section), job.warnings);
  if (announce) {
    const notes = (job.warnings || []).length;
    $("#announce").textContent = `${job.kind === "dub" ? "Dubbed" : "Said"}: ${result.summary}.` +
      (notes ? ` ${notes} note${notes > 1 ? "s" : ""} below.` : "") + " The video plays.";
    if (!live || document.activeElement === document.body || document.activeElement === $("#stop")) {
      $("#result-title").focus({ preventScroll: true });
    }
    if (!live) section.scrollIntoView({ block: "start", behavior: "instant" });
  }
}

function drawCues(cues, duration) {
  const strip = $("#cues");
  const head = $(".head", strip);
  strip.replaceChildren(head);
  for (const [start, end, value] of cues) {
    const cue = document.createElement("div");
    cue.className = `cue shape-${value}`;
    cue.style.left = `${(100 * start) / duration}%`;
    cue.style.width = `${(100 * (end - start)) / duration}%`;
    cue.textContent = value;
    cue.title = `${value}: ${SHAPES[value] || ""} (${start.toFixed(2)}-${end.toFixed(2)} s)`;
    strip.append(cue);
  }
  strip.dataset.duration = String(duration);
  moveHead(0);
}

function moveHead(time) {
  const job = state.shown;
  if (!job) return;
  const { cues, duration } = job.result;
  $("#cues .head").style.left = `${Math.min(100, (100 * time) / duration)}%`;
  const cue = cues.find(([start, end]) => time >= start && time < end) || cues[cues.length - 1];
  const value = cue ? cue[2] : "X";
  const shape = $("#shape-now");
  shape.textContent = value;
  shape.className = `shape shape-${value}`;
  $("#shape-what").textContent = SHAPES[value] || "";
}

function followPlayer() {
  const player = $("#player");
  let frame = null;
  const tick = () => {
    moveHead(player.currentTime);
    frame = player.paused ? null : requestAnimationFrame(tick);
  };
  player.addEventListener("play", () => { if (!frame) frame = requestAnimationFrame(tick); });
  player.addEventListener("seeked", () => moveHead(player.currentTime));
  player.addEventListener("timeupdate", () => { if (!frame) moveHead(player.currentTime); });
  $("#cues").addEventListener("click", (e) => {
    const strip = e.currentTarget.getBoundingClientRect();
    const duration = Number(e.currentTarget.dataset.duration || 0);
    if (duration) player.currentTime = ((e.clientX - strip.left) / strip.width) * duration;
  });
}

// -- the list of jobs

async function refreshJobs() {
  let jobs;
  try { jobs = await api("/api/jobs"); } catch (err) { return; }
  state.jobsRunning = jobs.some((j) => !FINAL.has(j.status));
  const list = $("#jobs");
  const focused = document.activeElement && list.contains(document.activeElement) ?
    [document.activeElement.closest("li").dataset.id, document.activeElement.className] : null;
  list.replaceChildren();
  for (const job of jobs.slice(0, 30)) {
    const item = document.createElement("li");
    item.dataset.id = job.id;
    const kind = document.createElement("span");
    kind.className = "kind";
    kind.textContent = job.kind;
    const status = document.createElement("span");
    status.className = `status ${job.status}`;
    status.textContent = job.status === "queued" && job.position ?
      `queued, ${ordinal(job.position)} in line` : job.status;
    const what = document.createElement("div");
    what.className = "what";
    const inputs = job.inputs || {};
    what.textContent = job.kind === "build"
      ? `${inputs.name || ""} from ${inputs.video || "a video"}`
      : `${inputs.model || ""}: ${inputs.text ? `"${inputs.text.slice(0, 60)}"` : inputs.recording || ""}`;
    item.append(kind, status, what);
    if (job.message && job.status !== "done") {
      const why = document.createElement("div");
      why.className = `why ${job.status}`;
      why.textContent = job.message;
      item.append(why);
    }
    if (job.cancellable) {
      const cancel = document.createElement("button");
      cancel.type = "button";
      cancel.className = "cancel";
      cancel.textContent = job.status === "queued" ? "Cancel" : "Stop";
      cancel.setAttribute("aria-label", `${cancel.textContent} this ${job.kind}`);
      cancel.addEventListener("click", async (e) => {
        e.stopPropagation();
        cancel.disabled = true;
        try { await post(`/api/jobs/${encodeURIComponent(job.id)}/cancel`); } catch (err) { /* its end says why */ }
        refreshJobs();
      });
      item.append(cancel);
    }
    if (job.status === "done" && job.result && job.result.video) {
      item.classList.add("openable");
      item.tabIndex = 0;
      item.setAttribute("role", "button");
      item.title = "show this result";
      item.setAttribute("aria-label", `show this ${job.kind}: ${what.textContent}`);
      const open = () => { showTab(job.kind); showResult(job, undefined, true); };
      item.addEventListener("click", open);
      item.addEventListener("keydown", (e) => {
        if (e.target === item && (e.key === "Enter" || e.key === " ")) { e.preventDefault(); open(); }
      });
    }
    list.append(item);
  }
  if (focused) {  // the list is drawn anew: the keyboard's place in it is kept
    const item = $$("#jobs li").find((li) => li.dataset.id === focused[0]);
    const again = item && (focused[1] === "cancel" ? $("button.cancel", item) : item);
    if (again) again.focus(); else list.closest("aside").focus();
  }
}

// The list of jobs follows the queue: every second while a job is not over, else every 5 s.
async function watchJobs() {
  for (;;) {
    await sleep(state.jobsRunning ? 1000 : 5000);
    if (!document.hidden) await refreshJobs();
  }
}

// -- start

function showTab(name) {
  for (const tab of $$(".tabs button")) tab.setAttribute("aria-selected", String(tab.dataset.tab === name));
  for (const panel of $$(".panel")) panel.hidden = panel.dataset.panel !== name;
  $("#result").hidden = name === "build" || !state.shown;
  if (name === "build") $("#player").pause();
}

async function start() {
  for (const tab of $$(".tabs button")) tab.addEventListener("click", () => showTab(tab.dataset.tab));
  $("#say-form").addEventListener("submit", (e) => { e.preventDefault(); submitSpeech(e.target, "say"); });
  $("#dub-form").addEventListener("submit", (e) => { e.preventDefault(); submitSpeech(e.target, "dub"); });
  $("#build-form").addEventListener("submit", (e) => { e.preventDefault(); submitBuild(e.target); });
  $("#cancel-build").addEventListener("click", async () => {
    if (!state.build) return;
    $("#cancel-build").disabled = true;
    try { await post(`/api/jobs/${encodeURIComponent(state.build)}/cancel`); } catch (err) {
      showError($("#build-form"), err.message);
    }
  });
  for (const form of [$("#say-form"), $("#dub-form")]) {
    $("textarea[name=text]", form).addEventListener("input", () => showCount(form));
    const audio = $("input[name=audio]", form);
    audio.addEventListener("change", () => {
      $("select[name=voice]", form).disabled = audio.files.length > 0;
      fillLipsync(form);
    });
  }
  $("#dub-form input[name=own]").addEventListener("change", () => {
    chooseModel(state.model && state.model.id);
    setBusy($("#dub-form"), null);
  });
  followPlayer();
  $("#stop").addEventListener("click", stopLive);
  try {
    state.config = await api("/api/config");
    for (const select of $$("select[name=voice]")) {
      for (const voice of state.config.voices) {
        select.append(new Option(`${voice.name}: ${voice.description}`, voice.name));
      }
      select.value = state.config.default_voice;
    }
    for (const form of [$("#say-form"), $("#dub-form")]) showCount(form);
    $("#server").textContent = `miketalk ${state.config.version} · uploads up to ${megabytes(state.config.max_upload_bytes)}`;
    await loadModels();
    await refreshJobs();
    watchJobs();
    const running = (await api("/api/jobs")).find((j) => j.kind === "build" && !FINAL.has(j.status));
    if (running) watchBuild(running);  // a reload goes on showing the build
  } catch (err) {
    showError($("#say-form"), err.message);
  }
  document.body.dataset.ready = "1";
}

start();
