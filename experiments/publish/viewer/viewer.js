/* placeholder: the report viewer (experiments/publish/viewer/viewer.js) replaces this file */
