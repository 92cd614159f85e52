// The study page: plays each trial of the participant's planned order, collects the answers and
// writes them as one CSV (served: POSTed to mse study serve; from file://: downloaded).
(function () {
  "use strict";
  const study = window.STUDY;
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.search);
  // ?speed=4: every clip 4 times faster (for the experimenter's own run-through, never for participants)
  const speed = Math.min(16, Math.max(0.25, Number(params.get("speed")) || 1));
  let participant = "";
  let trials = [];
  let rows = [];
  let readyAt = 0;
  let answered = false;

  function setState(state) {
    document.body.dataset.state = state;
  }

  function labelText(label) {
    return label.replace(/_/g, " ");
  }

  function begin() {
    const id = $("participant").value.trim();
    const plan = Object.prototype.hasOwnProperty.call(study.participants, id) ? study.participants[id] : null;
    if (!plan) {
      const known = Object.keys(study.participants);
      $("start-error").textContent = id
        ? `Unknown participant id "${id}": this study has ${known.join(", ")}.`
        : `Enter your participant id (${known[0]} … ${known[known.length - 1]}).`;
      return;
    }
    participant = id;
    trials = plan.labels.map((stimulus) => ({ task: "label", stimulus }))
      .concat(plan.pairs.map((pair) => ({ task: "pair", emotion: pair.emotion, left: pair.left, right: pair.right })));
    rows = [];
    $("start").hidden = true;
    $("trial").hidden = false;
    show(0);
  }

  function media(id, onDone) {
    const stimulus = study.stimuli[id];
    const figure = document.createElement("figure");
    if (stimulus.kind === "image") {
      const image = document.createElement("img");
      image.alt = "";
      image.addEventListener("load", () => setTimeout(onDone, study.duration * 1000 / speed));
      image.addEventListener("error", () => failed(stimulus.file));
      image.src = stimulus.file;
      figure.appendChild(image);
      return { figure, replay: null };
    }
    const video = document.createElement("video");
    video.muted = true;
    video.playsInline = true;
    video.preload = "auto";
    video.defaultPlaybackRate = speed;
    video.playbackRate = speed;
    video.addEventListener("ended", onDone);
    video.addEventListener("error", () => failed(stimulus.file));
    video.src = stimulus.file;
    video.autoplay = true;
    figure.appendChild(video);
    const replay = () => { video.currentTime = 0; video.playbackRate = speed; video.play(); };
    return { figure, replay };
  }

  function failed(file) {
    $("trial-error").textContent = `This browser cannot show ${file}. Please tell the experimenter.`;
    setState("error");
  }

  function show(index) {
    const trial = trials[index];
    const stage = $("stage");
    const choices = $("choices");
    stage.replaceChildren();
    choices.replaceChildren();
    $("replay").hidden = true;
    $("progress").textContent = `${index + 1} / ${trials.length}`;
    answered = false;
    let waiting = trial.task === "pair" ? 2 : 1;
    const players = [];
    const ready = () => {
      waiting -= 1;
      if (waiting > 0) return;
      readyAt = performance.now();
      for (const button of choices.querySelectorAll("button")) button.disabled = false;
      if (players.some((play) => play)) $("replay").hidden = false;
      setState("answer");
    };
    const add = (id, caption) => {
      const shown = media(id, ready);
      if (caption) {
        const text = document.createElement("figcaption");
        text.textContent = caption;
        shown.figure.appendChild(text);
      }
      stage.appendChild(shown.figure);
      players.push(shown.replay);
    };
    const choice = (text, response) => {
      const button = document.createElement("button");
      button.type = "button";
      button.textContent = text;
      button.dataset.response = response;
      button.disabled = true;
      button.addEventListener("click", () => answer(index, response));
      choices.appendChild(button);
    };
    if (trial.task === "label") {
      stage.className = "label";
      add(trial.stimulus, "");
      $("question").textContent = "Which emotion does the agent express?";
      for (const label of study.labels) choice(labelText(label), label);
    } else {
      stage.className = "pair";
      add(trial.left, "Left");
      add(trial.right, "Right");
      $("question").textContent = "Which of the two animations is more believable?";
      choice("Left", "left");
      choice("Right", "right");
    }
    $("replay").onclick = () => { for (const play of players) if (play) play(); };
    setState("playing");
  }

  function answer(index, response) {
    if (answered) return;
    answered = true;
    const trial = trials[index];
    const seconds = ((performance.now() - readyAt) / 1000).toFixed(3);
    if (trial.task === "label") {
      const stimulus = study.stimuli[trial.stimulus];
      rows.push([participant, "label", stimulus.emotion, stimulus.condition, response, trial.stimulus, index + 1, seconds]);
    } else {
      const left = study.stimuli[trial.left];
      const right = study.stimuli[trial.right];
      const chosen = response === "left" ? left : right;
      rows.push([participant, "pair", trial.emotion, `${left.condition}|${right.condition}`, chosen.condition,
        `${trial.left}|${trial.right}`, index + 1, seconds]);
    }
    if (index + 1 < trials.length) show(index + 1);
    else finish();
  }

  function csvField(value) {
    const text = String(value);
    return /[",\r\n]/.test(text) ? `"${text.replace(/"/g, '""')}"` : text;
  }

  function csv() {
    return [study.columns].concat(rows).map((row) => row.map(csvField).join(",")).join("\r\n") + "\r\n";
  }

  function offerDownload(text, message, state) {
    const link = $("download");
    link.href = URL.createObjectURL(new Blob([text], { type: "text/csv" }));
    link.download = `${participant}.csv`;
    link.hidden = false;
    $("status").textContent = message;
    setState(state);
    return link;
  }

  async function finish() {
    $("trial").hidden = true;
    $("done").hidden = false;
    const text = csv();
    if (location.protocol !== "http:" && location.protocol !== "https:") {
      offerDownload(text, `Your answers are downloaded as ${participant}.csv; please hand the file to the experimenter.`,
        "downloaded").click();
      return;
    }
    setState("saving");
    try {
      const reply = await fetch(`results/${encodeURIComponent(participant)}`, {
        method: "POST", headers: { "Content-Type": "text/csv; charset=utf-8" }, body: text,
      });
      if (!reply.ok) throw new Error(`${reply.status} ${(await reply.text()).trim()}`);
      $("status").textContent = "Your answers are saved. You may close this page.";
      setState("saved");
    } catch (error) {
      offerDownload(text, `The answers could not be saved (${error.message}); download them and hand the file ` +
        "to the experimenter.", "download");
    }
  }

  const given = params.get("participant");
  if (given) $("participant").value = given;
  $("begin").addEventListener("click", begin);
  $("participant").addEventListener("keydown", (event) => { if (event.key === "Enter") begin(); });
}());
