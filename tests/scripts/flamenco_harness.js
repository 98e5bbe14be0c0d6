// Test harness: runs a Flamenco job-type script in Node as Flamenco Manager runs it (a strict-mode script
// whose globals `author`, `path`, `print` and `alert` the Manager provides), with fakes that record what
// compileJob() authors.
//
//   node flamenco_harness.js JOB_TYPE.js                 -> {"jobType": JOB_TYPE}
//   node flamenco_harness.js JOB_TYPE.js SETTINGS_JSON   -> {"jobType": ..., "tasks": [{name, type, commands, dependencies}]}
//
// A compileJob() that throws: "compileJob: MESSAGE" on stderr, exit status 1.
"use strict";

const fs = require("fs");
const vm = require("vm");

const [scriptPath, settingsJson] = process.argv.slice(2);

// As the Manager's author module (internal/manager/job_compilers/author.go): names are trimmed and required.
const author = {
    Task(name, type) {
        name = String(name).trim();
        type = String(type).trim();
        if (name === "" || type === "") {
            throw new Error("author.Task(name, type): name and type are required");
        }
        return {
            name,
            type,
            commands: [],
            dependencies: [],
            addCommand(command) {
                this.commands.push(command);
            },
            addDependency(task) {
                this.dependencies.push(task.name);
            },
        };
    },
    Command(name, parameters, totalStepCount) {
        return { name, parameters, totalStepCount: totalStepCount || 0 };
    },
};

// As the Manager's path module (pkg/crosspath): backslashes separate too, on every platform.
const base = (p) => p.replaceAll("\\", "/").split("/").pop();
const path = {
    basename: base,
    dirname: (p) => p.replaceAll("\\", "/").split("/").slice(0, -1).join("/") || ".",
    join: (...parts) => parts.join("/").replace(/\/+/g, "/"),
    stem: (p) => {
        const name = base(p);
        const dot = name.lastIndexOf(".");
        return dot < 0 ? name : name.slice(0, dot);
    },
};

const log = (...args) => process.stderr.write(args.map(String).join(" ") + "\n");
const context = vm.createContext({ author, path, print: log, alert: log });
vm.runInContext('"use strict"; ' + fs.readFileSync(scriptPath, "utf8"), context, { filename: scriptPath });

const result = { jobType: vm.runInContext("JOB_TYPE", context) };
if (settingsJson !== undefined) {
    const job = {
        name: "test",
        settings: JSON.parse(settingsJson),
        created: new Date(0),
        tasks: [],
        addTask(task) {
            this.tasks.push(task);
        },
    };
    try {
        vm.runInContext("compileJob", context)(job);
    } catch (error) {
        process.stderr.write(`compileJob: ${error}\n`);
        process.exit(1);
    }
    result.tasks = job.tasks.map(({ name, type, commands, dependencies }) => ({ name, type, commands, dependencies }));
}
process.stdout.write(JSON.stringify(result));
