// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco job type "MPEG-4 Face Convert": one Blender task per MPEG-4 FAP stream, each running the
// per-stream command of scripts/convert.py on the Worker:
//
//   {blender} {blenderArgs} --background --python-exit-code 1 FACE.blend --python convert.py -- STREAM -o OUTDIR [options]
//
// Install: put this file in the `scripts` folder next to the `flamenco-manager` executable and restart the
// Manager (README.md, "Render farm (Flamenco)"). Its job type name comes from the file name: mpeg4-face-convert.

const JOB_TYPE = {
    label: "MPEG-4 Face Convert",
    description: "Bake MPEG-4 FAP streams on a face (Alembic, PC2 point cache, preview video, contact sheet), one task per stream",
    settings: [
        { key: "streams", type: "string", required: true,
          description: "FAP streams to convert, separated by ';' (absolute paths the Workers can read)" },
        { key: "convert_script", type: "string", subtype: "file_path", required: true,
          description: "The extension's scripts/convert.py where the Workers can read it (a copy alone will do where the extension is installed)" },
        { key: "output_dir", type: "string", subtype: "dir_path", required: true,
          description: "Folder for the outputs: STEM.abc, STEM.pc2, STEM.mp4, STEM_sheet.png and the log STEM.log per stream" },
        { key: "resolution", type: "int32", default: 480, propargs: { min: 16, max: 8192 },
          description: "Height and width of the preview in pixels" },
        { key: "frames", type: "string", default: "",
          description: "Stream frames to convert, FIRST:LAST (e.g. 0:100; either end may be left out); empty: all" },
        { key: "engine", type: "string", choices: ["WORKBENCH", "CYCLES"], default: "WORKBENCH",
          description: "Render engine of the preview" },
        { key: "video", type: "bool", default: true, description: "Render the preview video" },
        { key: "sheet", type: "int32", default: 12, propargs: { min: 0, max: 100 },
          description: "Frames on the contact sheet (0: no sheet)" },
        { key: "face_object", type: "string", default: "",
          description: "Name of the face mesh; empty: the first mesh with feature points" },

        // Set by Flamenco's Blender add-on to the file being submitted: the face.
        { key: "blendfile", type: "string", required: true, visible: "web",
          description: "The face .blend (set up, or with feature points to set it up from)" },
    ],
};

function compileJob(job) {
    const settings = job.settings;
    const streams = streamPaths(settings.streams);
    const options = convertOptions(settings);
    for (const stream of streams) {
        const task = author.Task(`convert-${path.stem(stream)}`, "blender");
        task.addCommand(author.Command("blender-render", {
            exe: "{blender}",
            exeArgs: "{blenderArgs}",
            // Without --python-exit-code a script that raises would still end the task as done.
            argsBefore: ["--background", "--python-exit-code", "1"],
            blendfile: settings.blendfile,
            args: ["--python", settings.convert_script, "--", stream, "-o", settings.output_dir].concat(options),
        }));
        job.addTask(task);
    }
}

// The streams, checked for what no single task can see: outputs are named after a stream's file name without
// its extension, so two streams with one such name (in any case) would overwrite each other.
function streamPaths(text) {
    const streams = String(text || "").split(/[;\n]/).map((s) => s.trim()).filter((s) => s !== "");
    if (streams.length === 0) {
        throw "no FAP streams given: list them in the setting 'streams', separated by ';'";
    }
    const seen = new Map();
    for (const stream of streams) {
        if (!/^([\\/{]|[A-Za-z]:[\\/])/.test(stream)) {
            throw `${stream}: give streams as absolute paths (the Workers run in folders of their own)`;
        }
        const key = path.stem(stream).toLowerCase();
        if (seen.has(key)) {
            throw `${seen.get(key)} and ${stream} would both write ${path.stem(stream)}.*: rename one`;
        }
        seen.set(key, stream);
    }
    return streams;
}

// The options that shape a stream's outputs, in the order convert.py's stream_options() writes them.
function convertOptions(settings) {
    const value = (key) => {
        const given = settings[key];
        return given === undefined || given === null ? JOB_TYPE.settings.find((s) => s.key === key).default : given;
    };
    const options = [
        "--resolution", String(value("resolution")),
        "--engine", String(value("engine")),
        "--sheet", String(value("sheet")),
    ];
    const frames = String(value("frames")).trim();
    if (frames !== "") {
        options.push(`--frames=${frames}`);
    }
    const face = String(value("face_object"));
    if (face !== "") {
        options.push(`--object=${face}`);
    }
    if (!value("video")) {
        options.push("--no-video");
    }
    return options;
}
