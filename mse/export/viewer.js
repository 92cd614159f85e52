// mse timeline viewer: hover tooltips, a playhead with play/pause, and an optional
// stick-figure player synchronised with it.  No network, no libraries.
(function () {
  "use strict";
  var svg = document.getElementById("timeline");
  var x0 = parseFloat(svg.dataset.x0);
  var scale = parseFloat(svg.dataset.scale);
  var duration = parseFloat(svg.dataset.duration);
  var playhead = document.getElementById("playhead");
  var clock = document.getElementById("clock");
  var scrub = document.getElementById("scrub");
  var button = document.getElementById("play");
  var tooltip = document.getElementById("tooltip");
  var bars = Array.prototype.slice.call(svg.querySelectorAll("g.bar"));
  var motionNode = document.getElementById("mse-motion");
  var motion = motionNode ? JSON.parse(motionNode.textContent) : null;
  var canvas = document.getElementById("figure");
  var caption = document.getElementById("figure-caption");
  var time = 0;
  var playing = false;
  var last = null;

  // -- hover: lexeme, start and stop of the bar under the pointer ------------------------
  bars.forEach(function (bar) {
    bar.addEventListener("mouseenter", function () {
      var d = bar.dataset;
      tooltip.textContent = "";
      var head = document.createElement("strong");
      head.textContent = d.lexeme;
      tooltip.appendChild(head);
      tooltip.appendChild(document.createTextNode(
        " (" + d.modality + ", " + d.id + ") start " + d.start + " s, stop " + d.stop + " s"));
      tooltip.hidden = false;
      bar.classList.add("hover");
    });
    bar.addEventListener("mousemove", function (event) {
      tooltip.style.left = (event.pageX + 14) + "px";
      tooltip.style.top = (event.pageY + 14) + "px";
    });
    bar.addEventListener("mouseleave", function () {
      tooltip.hidden = true;
      bar.classList.remove("hover");
    });
  });

  // -- stick figure ---------------------------------------------------------------------
  function activeClip(t) {
    if (!motion) { return -1; }
    var found = -1;
    motion.clips.forEach(function (clip, index) {
      if (clip.start <= t && t < clip.stop) { found = index; }
    });
    return found;
  }

  function drawFigure(t) {
    if (!canvas || !motion || motion.clips.length === 0) { return; }
    var index = activeClip(t);
    var clip = motion.clips[index >= 0 ? index : 0];
    var frame = 0;
    if (index >= 0) {
      frame = Math.min(clip.frames.length - 1, Math.floor((t - clip.start) * motion.fps));
    }
    var ctx = canvas.getContext("2d");
    var b = motion.bounds;
    var margin = 16;
    var span = Math.max(b[2] - b[0], b[3] - b[1], 1e-6);
    var s = (Math.min(canvas.width, canvas.height) - 2 * margin) / span;
    var ox = (canvas.width - (b[2] - b[0]) * s) / 2;
    var oy = (canvas.height - (b[3] - b[1]) * s) / 2;
    function px(v) { return ox + (v - b[0]) * s; }
    function py(v) { return canvas.height - (oy + (v - b[1]) * s); }
    ctx.fillStyle = "#fbfbfb";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    var points = clip.frames[frame];
    ctx.strokeStyle = index >= 0 ? "#263238" : "#b0bec5";
    ctx.lineWidth = 3;
    ctx.lineCap = "round";
    clip.parents.forEach(function (parent, joint) {
      if (parent < 0) { return; }
      ctx.beginPath();
      ctx.moveTo(px(points[2 * parent]), py(points[2 * parent + 1]));
      ctx.lineTo(px(points[2 * joint]), py(points[2 * joint + 1]));
      ctx.stroke();
    });
    ctx.fillStyle = index >= 0 ? "#e07a5f" : "#cfd8dc";
    for (var j = 0; j < points.length; j += 2) {
      ctx.beginPath();
      ctx.arc(px(points[j]), py(points[j + 1]), 3, 0, 2 * Math.PI);
      ctx.fill();
    }
    canvas.dataset.clip = String(index);
    canvas.dataset.frame = String(frame);
    caption.textContent = index >= 0
      ? clip.lexeme + " (" + clip.signal + "), frame " + frame
      : "no motion at this time";
  }

  // -- playhead -----------------------------------------------------------------------------
  function setTime(t) {
    time = Math.max(0, Math.min(duration, t));
    var x = x0 + time * scale;
    playhead.setAttribute("x1", x);
    playhead.setAttribute("x2", x);
    clock.textContent = time.toFixed(2) + " s";
    clock.dataset.time = time.toFixed(3);
    scrub.value = String(time);
    bars.forEach(function (bar) {
      var on = parseFloat(bar.dataset.start) <= time && time < parseFloat(bar.dataset.stop);
      bar.classList.toggle("active", on);
    });
    drawFigure(time);
    keepInView(x);
    // Other players on the page (the face) follow the same clock.
    document.dispatchEvent(new CustomEvent("mse-time", { detail: { time: time } }));
  }

  // A long timeline is wider than the window: the lane names stay at the left edge ...
  var stageBox = document.getElementById("stage");
  var laneNames = document.getElementById("lane-names");
  if (stageBox && laneNames) {
    stageBox.addEventListener("scroll", function () {
      var box = svg.getBoundingClientRect();
      var units = stageBox.scrollLeft * svg.viewBox.baseVal.width / box.width;
      laneNames.setAttribute("transform", "translate(" + units.toFixed(1) + " 0)");
    });
  }

  // ... and it scrolls so that the playhead stays visible.
  function keepInView(x) {
    var stage = document.getElementById("stage");
    if (!stage || stage.scrollWidth <= stage.clientWidth) { return; }
    var box = svg.getBoundingClientRect();
    var px = x * box.width / svg.viewBox.baseVal.width;
    if (px < stage.scrollLeft + 40 || px > stage.scrollLeft + stage.clientWidth - 40) {
      stage.scrollLeft = Math.max(0, px - stage.clientWidth / 3);
    }
  }

  function frameStep(now) {
    if (!playing) { return; }
    if (last !== null) { setTime(time + (now - last) / 1000); }
    last = now;
    if (time >= duration) {
      playing = false;
      button.textContent = "Play";
      return;
    }
    window.requestAnimationFrame(frameStep);
  }

  function toggle() {
    if (!playing && time >= duration) { setTime(0); }
    playing = !playing;
    button.textContent = playing ? "Pause" : "Play";
    last = null;
    if (playing) { window.requestAnimationFrame(frameStep); }
  }

  button.addEventListener("click", toggle);
  scrub.addEventListener("input", function () { setTime(parseFloat(scrub.value)); });
  document.addEventListener("keydown", function (event) {
    if (event.code === "Space" && event.target === document.body) {
      event.preventDefault();
      toggle();
    }
  });
  svg.addEventListener("click", function (event) {
    var box = svg.getBoundingClientRect();
    var userX = (event.clientX - box.left) * (svg.viewBox.baseVal.width / box.width);
    if (userX >= x0) { setTime((userX - x0) / scale); }
  });
  setTime(0);
})();
