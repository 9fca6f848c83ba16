// miketalk serve: live playback. A job's fragmented MP4 is fetched as the server writes it and
// appended to a MediaSource, so the face plays while the rest is still being made. Plain
// JavaScript, no library.
"use strict";

// The codecs of a fragmented MP4 from its first bytes (the moov's avcC and mp4a boxes), as
// MediaSource wants them: 'video/mp4; codecs="avc1.PPCCLL, mp4a.40.2"'.
function mp4Codecs(bytes) {
  const find = (name) => {
    const code = Array.from(name, (c) => c.charCodeAt(0));
    for (let i = 0; i + 4 <= bytes.length; i++) {
      if (bytes[i] === code[0] && bytes[i + 1] === code[1] && bytes[i + 2] === code[2] && bytes[i + 3] === code[3]) return i;
    }
    return -1;
  };
  const avcc = find("avcC");
  if (avcc < 0 || avcc + 8 > bytes.length) return null;
  const hex = (n) => n.toString(16).padStart(2, "0");
  const video = `avc1.${hex(bytes[avcc + 5])}${hex(bytes[avcc + 6])}${hex(bytes[avcc + 7])}`;
  const codecs = find("mp4a") >= 0 ? `${video}, mp4a.40.2` : video;
  return `video/mp4; codecs="${codecs}"`;
}

// Plays the stream at `url` in `player` as it comes. Returns a handle: `stop()` ends the
// fetch and the playback at once; `done` settles when the stream has ended (or was stopped).
// `stats` counts what the viewer saw: the first bytes come and the first frame shown
// (performance.now()), the times the video waited for data after it, and how long.
function playLive(player, url, { onFirstFrame, keepSeconds = 30 } = {}) {
  const aborter = new AbortController();
  const stats = { firstByte: null, firstFrame: null, stalls: 0, stalledSeconds: 0, bytes: 0, ended: false };
  const source = new MediaSource();
  const objectUrl = URL.createObjectURL(source);
  let buffer = null;
  let waitingSince = null;
  const pending = [];
  let finished = false;

  const onWaiting = () => {
    if (stats.firstFrame !== null && !stats.ended && waitingSince === null) {
      waitingSince = performance.now();
      stats.stalls += 1;
    }
  };
  const onPlaying = () => {
    if (waitingSince !== null) {
      stats.stalledSeconds += (performance.now() - waitingSince) / 1000;
      waitingSince = null;
    }
  };
  player.addEventListener("waiting", onWaiting);
  player.addEventListener("playing", onPlaying);
  const watchFrames = () => {
    if (!player.requestVideoFrameCallback) return;
    player.requestVideoFrameCallback(() => {
      if (stats.firstFrame === null) {
        stats.firstFrame = performance.now();
        if (onFirstFrame) onFirstFrame(stats.firstFrame);
      }
    });
  };

  // Append what has come when the buffer is free; drop what was played long ago (an hour's
  // text would fill the browser's quota otherwise).
  const pump = () => {
    if (!buffer || buffer.updating) return;
    const played = player.currentTime - keepSeconds;
    if (buffer.buffered.length && buffer.buffered.start(0) < played - 5) {
      buffer.remove(0, played);
      return;
    }
    if (pending.length) {
      const next = pending.shift();
      try {
        buffer.appendBuffer(next);
      } catch (err) {
        if (err.name === "QuotaExceededError") { pending.unshift(next); return; }
        throw err;
      }
      return;
    }
    if (finished && source.readyState === "open") {
      source.endOfStream();
    }
  };

  const done = (async () => {
    player.src = objectUrl;
    await new Promise((resolve) => source.addEventListener("sourceopen", resolve, { once: true }));
    URL.revokeObjectURL(objectUrl);  // attached: the URL is needed no more
    const response = await fetch(url, { signal: aborter.signal, headers: { "X-Miketalk": "1" } });
    if (!response.ok) {
      let doc = null;
      try { doc = await response.json(); } catch (err) { doc = null; }
      throw new Error((doc && doc.error) || `the server answered ${response.status}`);
    }
    const reader = response.body.getReader();
    let head = new Uint8Array(0);
    for (;;) {
      const { value, done: over } = await reader.read();
      if (over) break;
      if (stats.firstByte === null) stats.firstByte = performance.now();
      stats.bytes += value.length;
      if (!buffer) {  // the codecs are in the first bytes: wait for them
        const joined = new Uint8Array(head.length + value.length);
        joined.set(head);
        joined.set(value, head.length);
        head = joined;
        const type = mp4Codecs(head);
        if (!type) continue;
        if (!MediaSource.isTypeSupported(type)) throw new Error(`this browser cannot play ${type}`);
        buffer = source.addSourceBuffer(type);
        buffer.mode = "segments";
        buffer.addEventListener("updateend", pump);
        pending.push(head);
        watchFrames();
        player.play().catch(() => { /* autoplay refused: the controls are there */ });
      } else {
        pending.push(value);
      }
      pump();
    }
    finished = true;
    pump();
    if (stats.bytes === 0) throw new Error("the stream ended before its first frame");
  })().finally(() => {
    stats.ended = true;
    onPlaying();
  });

  return {
    stats,
    done,
    stop() {
      aborter.abort();
      player.pause();
      stats.ended = true;
      player.removeEventListener("waiting", onWaiting);
      player.removeEventListener("playing", onPlaying);
    },
  };
}
